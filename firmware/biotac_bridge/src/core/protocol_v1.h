// Protocol v1 frames (docs/tactile_protocol.md): binary (96 bytes, CRC-16/CCITT-FALSE)
// and text ("F<finger>,<seq>,<v1>,...,<v44>\n"). No allocation, no I/O.
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace proto {

constexpr size_t kValues = 44;
constexpr size_t kBinaryFrameBytes = 96;
constexpr size_t kTextFrameMax = 2 + 3 + 1 + 5 + 1 + kValues * 5 + 1;  // "F255,65535," + 44 x "4095," + '\n'
constexpr uint16_t kValueMax = 4095;
constexpr uint8_t kSync0 = 0xAA;
constexpr uint8_t kSync1 = 0x55;

// CRC-16/CCITT-FALSE: polynomial 0x1021, initial 0xFFFF, MSB first, no final XOR.
uint16_t crc16_ccitt_false(const uint8_t* data, size_t len, uint16_t crc = 0xFFFF);

// Writes one binary frame into out[96]. Values above 4095 are saturated to 4095.
void build_binary(uint8_t finger, uint16_t seq, const uint16_t values[kValues], uint8_t out[kBinaryFrameBytes]);

// Writes one text line (with '\n') into out; returns its length, or 0 if cap is too
// small (kTextFrameMax always suffices). Values above 4095 are saturated.
size_t build_text(uint8_t finger, uint16_t seq, const uint16_t values[kValues], char* out, size_t cap);

}  // namespace proto
