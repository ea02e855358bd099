// The hardware layer: the only part that differs between the Teensy and the host
// build. The Teensy build implements it with SPI + digitalWrite chip-selects,
// delayMicroseconds and the USB serial port; the host build with simulated BioTacs
// and a pseudo-terminal or standard output.
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace hal {

// One SPI bus, one active-low chip-select per sensor (index 0..n-1).
class SpiBus {
 public:
  virtual ~SpiBus() = default;
  virtual void select(size_t sensor) = 0;    // chip-select low
  virtual void deselect(size_t sensor) = 0;  // chip-select high
  virtual uint16_t transfer16(uint16_t mosi) = 0;
  virtual uint8_t transfer8(uint8_t mosi) = 0;
  virtual void delay_us(uint32_t us) = 0;
};

// The link to the computer (USB CDC). Must never block.
class ByteSink {
 public:
  virtual ~ByteSink() = default;
  virtual size_t writable() = 0;                          // bytes write() takes now
  virtual size_t write(const uint8_t* data, size_t n) = 0;  // returns bytes taken
};

}  // namespace hal
