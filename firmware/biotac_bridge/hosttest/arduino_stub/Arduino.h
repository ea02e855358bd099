// Declarations-only stand-in for the parts of the Teensyduino core that
// src/teensy/main.cpp uses, so that `make teensy-check` can compile that file with
// the host compiler. Not an implementation, and no substitute for a real Teensy build.
#pragma once
#include <stddef.h>
#include <stdint.h>

#define HIGH 1
#define LOW 0
#define OUTPUT 1
#define MSBFIRST 1
#define SPI_MODE0 0x00

void pinMode(uint8_t pin, uint8_t mode);
void digitalWriteFast(uint8_t pin, uint8_t val);
void delay(uint32_t ms);
void delayMicroseconds(uint32_t us);

class usb_serial_class {
 public:
  void begin(long baud);
  int available();
  int read();
  int availableForWrite();
  size_t write(const uint8_t* buffer, size_t size);
  operator bool();
};
extern usb_serial_class Serial;

void setup();
void loop();
