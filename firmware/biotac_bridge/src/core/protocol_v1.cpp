#include "protocol_v1.h"

namespace proto {

uint16_t crc16_ccitt_false(const uint8_t* data, size_t len, uint16_t crc) {
  for (size_t i = 0; i < len; ++i) {
    crc = static_cast<uint16_t>(crc ^ (data[i] << 8));
    for (int b = 0; b < 8; ++b) {
      const bool top = (crc & 0x8000) != 0;
      crc = static_cast<uint16_t>(crc << 1);
      if (top) crc = static_cast<uint16_t>(crc ^ 0x1021);
    }
  }
  return crc;
}

static uint16_t saturate(uint16_t v) { return v > kValueMax ? kValueMax : v; }

void build_binary(uint8_t finger, uint16_t seq, const uint16_t values[kValues], uint8_t out[kBinaryFrameBytes]) {
  out[0] = kSync0;
  out[1] = kSync1;
  out[2] = finger;
  out[3] = static_cast<uint8_t>(seq & 0xFF);
  out[4] = static_cast<uint8_t>(seq >> 8);
  out[5] = static_cast<uint8_t>(kValues);
  for (size_t i = 0; i < kValues; ++i) {
    const uint16_t v = saturate(values[i]);
    out[6 + 2 * i] = static_cast<uint8_t>(v & 0xFF);
    out[7 + 2 * i] = static_cast<uint8_t>(v >> 8);
  }
  const uint16_t crc = crc16_ccitt_false(out + 2, kBinaryFrameBytes - 4);
  out[kBinaryFrameBytes - 2] = static_cast<uint8_t>(crc & 0xFF);
  out[kBinaryFrameBytes - 1] = static_cast<uint8_t>(crc >> 8);
}

// Appends the decimal digits of v; returns the new position.
static size_t put_uint(char* out, size_t pos, uint32_t v) {
  char tmp[10];
  size_t n = 0;
  do {
    tmp[n++] = static_cast<char>('0' + v % 10);
    v /= 10;
  } while (v != 0);
  while (n > 0) out[pos++] = tmp[--n];
  return pos;
}

size_t build_text(uint8_t finger, uint16_t seq, const uint16_t values[kValues], char* out, size_t cap) {
  if (cap < kTextFrameMax) return 0;
  size_t pos = 0;
  out[pos++] = 'F';
  pos = put_uint(out, pos, finger);
  out[pos++] = ',';
  pos = put_uint(out, pos, seq);
  for (size_t i = 0; i < kValues; ++i) {
    out[pos++] = ',';
    pos = put_uint(out, pos, saturate(values[i]));
  }
  out[pos++] = '\n';
  return pos;
}

}  // namespace proto
