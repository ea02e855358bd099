// Declarations-only stand-in (see Arduino.h in this folder).
#pragma once

class IntervalTimer {
 public:
  bool begin(void (*funct)(), float microseconds);
  void end();
};
