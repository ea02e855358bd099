#include "sim_biotac.h"

#include <math.h>
#include <stdio.h>

#include "../core/biotac_spi.h"

namespace sim {

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr double kPeriodS = 3.0;  // one press per 3 s
// Electrodes that sit under the pressed pad (0-based e index): their impedance drops.
bool under_pad(size_t e) { return e >= 6 && e <= 10; }

uint16_t clamp12(double v) {
  if (v < 0.0) return 0;
  if (v > 4095.0) return 4095;
  return static_cast<uint16_t>(lround(v));
}
}  // namespace

SimBioTac::SimBioTac(unsigned index, bool present)
    : index_(index), present_(present), rng_(0x9E3779B9u ^ (index * 2654435761u)) {
  snprintf(serial_, sizeof(serial_), "BT-SIM-%04u", index);
  snprintf(firmware_, sizeof(firmware_), "sim-1.0");
}

void SimBioTac::chip_select(bool low) { selected_ = low; }

uint32_t SimBioTac::noise() {
  rng_ = rng_ * 1664525u + 1013904223u;
  return rng_ >> 8;
}

double SimBioTac::press(double t_s) const {
  // free 1.0 s, press 0.6 s, hold 0.6 s, release 0.6 s, free 0.2 s; phase per sensor.
  const double u = fmod(t_s + 0.7 * index_, kPeriodS);
  if (u < 1.0) return 0.0;
  if (u < 1.6) return 0.5 - 0.5 * cos(kPi * (u - 1.0) / 0.6);
  if (u < 2.2) return 1.0;
  if (u < 2.8) return 0.5 + 0.5 * cos(kPi * (u - 2.2) / 0.6);
  return 0.0;
}

uint16_t SimBioTac::value_at(uint8_t channel, double t_s) {
  const double f = press(t_s);
  const double jitter = static_cast<double>(noise() % 5) - 2.0;  // -2..2 counts
  if (channel == bt::kPdc) return clamp12(2000.0 + 25.0 * index_ + 650.0 * f + jitter);
  if (channel == bt::kTdc) return clamp12(2700.0 + 3.0 * index_ + jitter * 0.5);
  if (channel == bt::kTac) return clamp12(2048.0 + jitter);
  if (channel == bt::kPac) {
    const double df = (press(t_s + 1e-3) - press(t_s - 1e-3)) / 2e-3;  // 1/s
    const double vib = 120.0 * df * sin(2.0 * kPi * 45.0 * t_s);
    return clamp12(2048.0 + vib + 3.0 * jitter);
  }
  if (channel >= bt::kE01 && channel <= bt::kE19) {
    const size_t e = static_cast<size_t>(channel - bt::kE01);
    const double base = 2750.0 + 15.0 * static_cast<double>(e) + 10.0 * index_;
    const double change = under_pad(e) ? -420.0 * f : 70.0 * f;
    return clamp12(base + change + jitter);
  }
  return 0;
}

uint16_t SimBioTac::transfer16(uint16_t mosi) {
  if (!present_ || !selected_) return 0xFFFF;
  const uint8_t hi = static_cast<uint8_t>(mosi >> 8);
  if (mosi == 0x0000) {  // read the reply of the last sampling command
    const uint16_t r = have_reply_ ? reply_ : 0xA55F;  // 'E_': no data
    have_reply_ = false;
    return r;
  }
  if (hi == bt::kReadCommand) {
    const uint8_t prop = static_cast<uint8_t>(mosi & 0xFF);
    prop_ = prop == bt::kPropSerialNumber ? serial_ : prop == bt::kPropFirmwareVersion ? firmware_ : "";
    prop_pos_ = 0;
    return 0x0000;
  }
  if (hi & 0x80) {
    const int ch = bt::command_channel(hi);
    if (ch < 0) {
      reply_ = 0xA545;  // 'EE': parity error in the command
    } else {
      reply_ = bt::encode_reply(value_at(static_cast<uint8_t>(ch), time_s()));
      ++samples_;
    }
    have_reply_ = true;
    return 0x0000;
  }
  return 0xA53F;  // 'E?': unknown command
}

uint8_t SimBioTac::transfer8(uint8_t mosi) {
  (void)mosi;
  if (!present_ || !selected_) return 0xFF;
  if (prop_ == nullptr) return 0x00;
  const char c = prop_[prop_pos_];
  if (c == '\0') {
    prop_ = nullptr;
    return 0x00;
  }
  ++prop_pos_;
  return static_cast<uint8_t>(c);
}

}  // namespace sim
