// Teensy 4.0 / 4.1 entry point (Arduino core, Teensyduino): the hardware layer of the
// bridge. SPI0 with one chip-select pin per BioTac, a 4.4 kHz IntervalTimer for the
// sampler, and the USB serial port (CDC) as the link, written only as far as it has
// room (never blocks). See docs/firmware.md for wiring and bring-up.
#ifdef ARDUINO

#include <Arduino.h>
#include <IntervalTimer.h>
#include <SPI.h>

#include "../core/bridge.h"

namespace {

// ------------------------------------------------------------------ configuration
// Chip-select pin of each BioTac (active low), and the protocol finger number that
// sensor reports: it must equal the finger's sensor_id in the hand file.
constexpr uint8_t kCsPins[] = {10, 9, 8, 7};
constexpr uint8_t kFingerIds[] = {0, 1, 2, 3};
constexpr size_t kSensors = sizeof(kCsPins) / sizeof(kCsPins[0]);
static_assert(sizeof(kFingerIds) == kSensors, "one finger number per chip-select");
static_assert(kSensors <= bridge::kMaxSensors, "too many sensors");

// SPI mode 0, MSB first (BioTac SPI interface); 4.4 MHz as SynTouch's adapter uses.
constexpr uint32_t kSpiHz = bt::kSpiClockHz;

// When each reply is read: 50 us after its command in the same tick (SynTouch's
// sequence), or on the next tick (less time in the interrupt; see src/core/bridge.h).
constexpr bridge::ReadTiming kReadTiming = bridge::ReadTiming::kSameTick;

#if defined(BRIDGE_TEXT_MODE) && BRIDGE_TEXT_MODE
constexpr bridge::Mode kStartMode = bridge::Mode::kText;
#else
constexpr bridge::Mode kStartMode = bridge::Mode::kBinary;
#endif

// ------------------------------------------------------------------ hardware layer

class TeensySpi final : public hal::SpiBus {
 public:
  void select(size_t s) override { digitalWriteFast(kCsPins[s], LOW); }
  void deselect(size_t s) override { digitalWriteFast(kCsPins[s], HIGH); }
  uint16_t transfer16(uint16_t mosi) override { return SPI.transfer16(mosi); }
  uint8_t transfer8(uint8_t mosi) override { return SPI.transfer(mosi); }
  void delay_us(uint32_t us) override { delayMicroseconds(us); }
};

class UsbSink final : public hal::ByteSink {
 public:
  size_t writable() override {
    const int n = Serial.availableForWrite();
    return n > 0 ? static_cast<size_t>(n) : 0;
  }
  size_t write(const uint8_t* data, size_t n) override { return Serial.write(data, n); }
};

TeensySpi g_spi;
UsbSink g_link;
bridge::Sampler g_sampler(g_spi, kSensors, kReadTiming);
bridge::Bridge g_bridge(g_link, kFingerIds, kSensors, kStartMode);
bridge::SensorInfo g_infos[kSensors];
bridge::Sampler::Frame g_frame;
IntervalTimer g_timer;
const SPISettings kSpiSettings(kSpiHz, MSBFIRST, SPI_MODE0);
bool g_host_was_open = false;

void on_tick() {  // 4.4 kHz, interrupt context
  SPI.beginTransaction(kSpiSettings);
  g_sampler.tick();
  SPI.endTransaction();
}

}  // namespace

void setup() {
  Serial.begin(1000000);  // nominal on USB CDC
  for (size_t s = 0; s < kSensors; ++s) {
    pinMode(kCsPins[s], OUTPUT);
    digitalWriteFast(kCsPins[s], HIGH);
  }
  SPI.begin();
  delay(200);  // let the BioTacs power up
  SPI.beginTransaction(kSpiSettings);
  for (size_t s = 0; s < kSensors; ++s) g_infos[s] = bridge::probe_sensor(g_spi, s);
  SPI.endTransaction();
  g_bridge.queue_info(g_infos, kSpiHz);
  g_timer.begin(on_tick, 1000000.0f / static_cast<float>(bt::kSampleRateHz));
}

void loop() {
  if (g_sampler.take(g_frame)) g_bridge.push_frame(g_frame);
  g_bridge.pump();
  while (Serial.available() > 0) {
    const int c = Serial.read();
    if (c >= 0)
      g_bridge.on_host_byte(static_cast<uint8_t>(c), g_infos, kSpiHz, g_sampler.overruns(), g_sampler.bad_replies());
  }
  // A host opened the port (DTR raised): drop the stale queue, repeat the start-up report.
  const bool open = static_cast<bool>(Serial);
  if (open && !g_host_was_open) {
    g_bridge.discard_queued();
    g_bridge.queue_info(g_infos, kSpiHz);
  }
  g_host_was_open = open;
}

#endif  // ARDUINO
