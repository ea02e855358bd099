// A simulated BioTac on the host: an SPI peer that answers the sampling and read
// commands in the BioTac's reply layout (biotac_spi.h), with values from a slow
// press-and-release profile so that pdc and the electrodes move. Its clock is the
// number of sampling commands it has received (4400 per simulated second).
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace sim {

class SimBioTac {
 public:
  // index: which sensor (changes baselines and the press phase); present=false: no
  // sensor on this chip-select (MISO stays high: every byte reads 0xFF).
  SimBioTac(unsigned index, bool present);

  void chip_select(bool low);
  uint16_t transfer16(uint16_t mosi);
  uint8_t transfer8(uint8_t mosi);

  // The value the sensor would report for a channel at simulated time t_s.
  uint16_t value_at(uint8_t channel, double t_s);
  double press(double t_s) const;  // 0..1, the press profile
  double time_s() const { return static_cast<double>(samples_) / 4400.0; }

 private:
  uint32_t noise();  // deterministic pseudo-random numbers

  unsigned index_;
  bool present_;
  bool selected_ = false;
  uint64_t samples_ = 0;
  uint32_t rng_;
  bool have_reply_ = false;
  uint16_t reply_ = 0;
  const char* prop_ = nullptr;  // property string being clocked out
  size_t prop_pos_ = 0;
  char serial_[20] = {};
  char firmware_[12] = {};
};

}  // namespace sim
