// BioTac SPI interface: command words, parity, reply layout and the standard
// 44-sample frame. Pure functions and constants, shared by the Teensy build, the
// host build and the simulated BioTac.
//
// Facts used here (SynTouch BioTac, SPI interface version 2), from SynTouch's public
// documentation of the sensor: the BioTac Product Manual (V21, Aug. 2018, "Sensor
// Electronics" / sensor output) and the BioTac C library for the Cheetah SPI adapter
// that SynTouch published with it (biotac.h / biotac.c, (c) SynTouch LLC 2011-2012,
// redistributed in the ROS package biotac_sensors). Nothing below is copied from them;
// the values are restated and the code is written from these facts:
//
//  * Bus: SPI mode 0 (CPOL 0, CPHA 0), most significant bit first, 16-bit words.
//    SynTouch's adapter clocks the bus at 4.4 MHz; chip-select is active low.
//  * Sampling command: one byte 0b1CCCCCCP, i.e. bit 7 set, the 6-bit channel index
//    in bits 6..1 and an odd-parity bit in bit 0 (the byte always has an odd number of
//    ones), sent as the high byte of a 16-bit word whose low byte is 0x00.
//    Channel indices: PAC 0, PDC 1, TAC 2, TDC 3, HAL 15, E01..E19 = 17..35.
//    Resulting command bytes: PAC 0x80, PDC 0x83, TAC 0x85, TDC 0x86,
//    E01 0xA2, E02 0xA4, E03 0xA7, ... E19 0xC7.
//  * Reply: the sample is read with a further 16-bit transfer (MOSI 0x0000), at least
//    ~50 us after the sampling command (SynTouch's default after-sample delay is 50 us
//    and their inter-word delay 10 us). Each reply byte carries odd parity in bit 0:
//    high byte bits 7..1 = D11..D5, low byte bits 7..3 = D4..D0 (bits 2..1 unused),
//    so value = (hi >> 1) * 32 + (lo >> 3), an unsigned 12-bit count.
//  * Error replies start with 0xA5 ('E' shifted into the 7-bit field with wrong
//    parity), e.g. 0xA545 parity error of the command, 0xA53F unknown command; they
//    fail the parity check and are treated as bad replies.
//  * Standard sampling: 4400 samples/s per sensor, a frame of 44 samples in which
//    every second sample is PAC (22 PAC samples, 2.2 kHz) and the others run
//    E01..E19, PDC, TAC, TDC once each: one complete frame every 10 ms (100 Hz).
//  * Properties: the read command 0x61 followed by a property byte (firmware version
//    0x13, serial number 0x15, flex-circuit version 0x10) in one 16-bit word; the
//    answer is then clocked out one byte per transfer (MOSI 0x00) as ASCII, ending
//    with '\0' (or 0xFF). A connected BioTac's serial number starts with "BT".
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace bt {

// Channel indices of the sampling command (bits 6..1 of the command byte).
enum Channel : uint8_t {
  kPac = 0,
  kPdc = 1,
  kTac = 2,
  kTdc = 3,
  kHal = 15,
  kE01 = 17,  // E01..E19 are 17..35
  kE19 = 35,
};

constexpr uint32_t kSampleRateHz = 4400;   // samples per second per sensor
constexpr size_t kFrameSamples = 44;       // samples per frame -> 100 Hz frames
constexpr size_t kPacPerFrame = 22;
constexpr uint32_t kAfterSampleDelayUs = 50;
constexpr uint32_t kInterWordDelayUs = 10;
constexpr uint32_t kSpiClockHz = 4400000;

constexpr uint8_t kReadCommand = 0x61;
constexpr uint8_t kPropFlexVersion = 0x10;
constexpr uint8_t kPropFirmwareVersion = 0x13;
constexpr uint8_t kPropSerialNumber = 0x15;

constexpr int popcount8(uint8_t v) {
  int n = 0;
  for (int i = 0; i < 8; ++i) n += (v >> i) & 1;
  return n;
}

// A 7-bit payload placed in bits 7..1 with the odd-parity bit in bit 0.
constexpr uint8_t with_odd_parity(uint8_t payload7) {
  const uint8_t shifted = static_cast<uint8_t>((payload7 & 0x7F) << 1);
  return static_cast<uint8_t>(shifted | ((popcount8(shifted) % 2 == 0) ? 1 : 0));
}

constexpr bool odd_parity_ok(uint8_t byte) { return popcount8(byte) % 2 == 1; }

// The sampling command byte for a channel index (0..63).
constexpr uint8_t sampling_command(uint8_t channel) {
  return with_odd_parity(static_cast<uint8_t>(0x40 | (channel & 0x3F)));
}

// The 16-bit word put on MOSI to sample a channel.
constexpr uint16_t sampling_word(uint8_t channel) {
  return static_cast<uint16_t>(sampling_command(channel) << 8);
}

// Channel index of a command byte, or -1 when it is not a sampling command with
// good parity.
constexpr int command_channel(uint8_t cmd) {
  return ((cmd & 0x80) && odd_parity_ok(cmd)) ? ((cmd >> 1) & 0x3F) : -1;
}

// Reply word (hi << 8 | lo) for a 12-bit value, as the sensor sends it.
constexpr uint16_t encode_reply(uint16_t value12) {
  const uint8_t hi = with_odd_parity(static_cast<uint8_t>((value12 >> 5) & 0x7F));
  const uint8_t lo5 = static_cast<uint8_t>(value12 & 0x1F);
  const uint8_t lo_body = static_cast<uint8_t>(lo5 << 3);
  const uint8_t lo = static_cast<uint8_t>(lo_body | ((popcount8(lo_body) % 2 == 0) ? 1 : 0));
  return static_cast<uint16_t>((hi << 8) | lo);
}

struct Reply {
  uint16_t value;  // 0..4095
  bool parity_ok;  // both bytes have odd parity
};

constexpr Reply decode_reply(uint16_t word) {
  const uint8_t hi = static_cast<uint8_t>(word >> 8);
  const uint8_t lo = static_cast<uint8_t>(word & 0xFF);
  const uint16_t value = static_cast<uint16_t>(((hi >> 1) << 5) | (lo >> 3));
  return Reply{value, odd_parity_ok(hi) && odd_parity_ok(lo)};
}

// Channel sampled at position k (0..43) of the standard frame: odd positions are
// PAC, even positions 0,2,..,36 are E01..E19, then 38 PDC, 40 TAC, 42 TDC.
constexpr uint8_t frame_channel(size_t k) {
  if (k % 2 == 1) return kPac;
  const size_t j = k / 2;  // 0..21
  if (j < 19) return static_cast<uint8_t>(kE01 + j);
  if (j == 19) return kPdc;
  if (j == 20) return kTac;
  return kTdc;
}

// Where the sample taken at frame position k goes in the protocol v1 value order
// (e1..e19 at 0..18, pdc 19, pac1..pac22 at 20..41, tdc 42, tac 43).
constexpr size_t protocol_index(size_t k) {
  if (k % 2 == 1) return 20 + k / 2;  // pac1..pac22
  const size_t j = k / 2;
  if (j < 19) return j;   // e1..e19
  if (j == 19) return 19; // pdc
  if (j == 20) return 43; // tac
  return 42;              // tdc
}

// Compile-time checks against the command bytes listed in SynTouch's documentation.
static_assert(sampling_command(kPac) == 0x80, "PAC command");
static_assert(sampling_command(kPdc) == 0x83, "PDC command");
static_assert(sampling_command(kTac) == 0x85, "TAC command");
static_assert(sampling_command(kTdc) == 0x86, "TDC command");
static_assert(sampling_command(kHal) == 0x9E, "HAL command");
static_assert(sampling_command(kE01) == 0xA2, "E01 command");
static_assert(sampling_command(kE01 + 2) == 0xA7, "E03 command");
static_assert(sampling_command(kE01 + 15) == 0xC1, "E16 command");
static_assert(sampling_command(kE19) == 0xC7, "E19 command");
static_assert(decode_reply(encode_reply(4095)).value == 4095, "reply round trip");
static_assert(!decode_reply(0xA545).parity_ok, "error replies fail parity");

}  // namespace bt
