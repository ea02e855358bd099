// Declarations-only stand-in (see Arduino.h in this folder).
#pragma once
#include <stdint.h>

class SPISettings {
 public:
  SPISettings(uint32_t clock, uint8_t bitOrder, uint8_t dataMode);
};

class SPIClass {
 public:
  void begin();
  void beginTransaction(SPISettings settings);
  void endTransaction();
  uint8_t transfer(uint8_t data);
  uint16_t transfer16(uint16_t data);
};
extern SPIClass SPI;
