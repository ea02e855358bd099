// Host unit tests of the bridge pieces: BioTac command words and parity, reply
// decoding, the 44-sample frame, protocol v1 frames and CRC against the worked
// example of docs/tactile_protocol.md, the sampler mailbox and the non-blocking queue.
// Built and run by `make test`; exits non-zero on the first failed check.
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <string>
#include <vector>

#include "../src/core/biotac_spi.h"
#include "../src/core/bridge.h"
#include "../src/core/protocol_v1.h"
#include "../src/host/sim_biotac.h"

static int g_checks = 0;
static int g_tests = 0;

#define CHECK(cond)                                                             \
  do {                                                                          \
    ++g_checks;                                                                 \
    if (!(cond)) {                                                              \
      fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
      exit(1);                                                                  \
    }                                                                           \
  } while (0)

#define TEST(name) static void name()
#define RUN(name)  \
  do {             \
    name();        \
    ++g_tests;     \
    printf("ok %s\n", #name); \
  } while (0)

// ------------------------------------------------------------------ BioTac SPI

// Command bytes as listed in SynTouch's documentation (PAC, PDC, TAC, TDC, E01..E19).
static const uint8_t kDocumented[23] = {0x80, 0x83, 0x85, 0x86, 0xA2, 0xA4, 0xA7, 0xA8, 0xAB, 0xAD, 0xAE, 0xB0,
                                        0xB3, 0xB5, 0xB6, 0xB9, 0xBA, 0xBC, 0xBF, 0xC1, 0xC2, 0xC4, 0xC7};

TEST(command_words_match_documentation) {
  const uint8_t channels[23] = {0, 1, 2, 3, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35};
  for (int i = 0; i < 23; ++i) {
    const uint8_t cmd = bt::sampling_command(channels[i]);
    CHECK(cmd == kDocumented[i]);
    CHECK(bt::odd_parity_ok(cmd));
    CHECK((cmd & 0x80) != 0);
    CHECK(bt::command_channel(cmd) == channels[i]);
    CHECK(bt::sampling_word(channels[i]) == static_cast<uint16_t>(cmd << 8));
    for (int bit = 0; bit < 8; ++bit) {  // any single bit error is caught by the parity
      CHECK(!bt::odd_parity_ok(static_cast<uint8_t>(cmd ^ (1u << bit))));
    }
  }
}

TEST(every_sampling_command_has_odd_parity) {
  for (uint8_t ch = 0; ch < 64; ++ch) {
    const uint8_t cmd = bt::sampling_command(ch);
    CHECK(bt::popcount8(cmd) % 2 == 1);
    CHECK(bt::command_channel(cmd) == ch);
  }
}

TEST(reply_layout_round_trip_and_parity) {
  // 0xABC: D11..D5 = 1010101 -> hi 0xAB (parity 1), D4..D0 = 11100 -> lo 0xE0 (parity 0).
  CHECK(bt::encode_reply(0xABC) == 0xABE0);
  CHECK(bt::decode_reply(0xABE0).value == 0xABC);
  CHECK(bt::decode_reply(0xABE0).parity_ok);
  CHECK(bt::encode_reply(0) == 0x0101);
  for (uint16_t v = 0; v < 4096; ++v) {
    const uint16_t w = bt::encode_reply(v);
    const bt::Reply r = bt::decode_reply(w);
    CHECK(r.parity_ok && r.value == v);
    CHECK((w & 0x06) == 0);  // low byte bits 2..1 unused
    for (int bit = 0; bit < 16; ++bit) CHECK(!bt::decode_reply(static_cast<uint16_t>(w ^ (1u << bit))).parity_ok);
  }
  // Nobody answering (MISO pulled high or low) and the sensor's error words fail.
  CHECK(!bt::decode_reply(0xFFFF).parity_ok);
  CHECK(!bt::decode_reply(0x0000).parity_ok);
  CHECK(!bt::decode_reply(0xA545).parity_ok);
  CHECK(!bt::decode_reply(0xA53F).parity_ok);
}

TEST(standard_frame_sequence) {
  int pac = 0;
  int seen[64] = {};
  bool index_used[44] = {};
  for (size_t k = 0; k < bt::kFrameSamples; ++k) {
    const uint8_t ch = bt::frame_channel(k);
    if (ch == bt::kPac) {
      ++pac;
      CHECK(k % 2 == 1);
    }
    ++seen[ch];
    const size_t idx = bt::protocol_index(k);
    CHECK(idx < 44 && !index_used[idx]);
    index_used[idx] = true;
    // protocol order: e1..e19 0..18, pdc 19, pac 20..41, tdc 42, tac 43
    if (ch >= bt::kE01 && ch <= bt::kE19) CHECK(idx == static_cast<size_t>(ch - bt::kE01));
    if (ch == bt::kPdc) CHECK(idx == 19);
    if (ch == bt::kPac) CHECK(idx >= 20 && idx <= 41);
    if (ch == bt::kTdc) CHECK(idx == 42);
    if (ch == bt::kTac) CHECK(idx == 43);
  }
  CHECK(pac == 22);
  for (uint8_t ch = bt::kE01; ch <= bt::kE19; ++ch) CHECK(seen[ch] == 1);
  CHECK(seen[bt::kPdc] == 1 && seen[bt::kTac] == 1 && seen[bt::kTdc] == 1);
  CHECK(bt::kSampleRateHz / bt::kFrameSamples == 100);
}

// ------------------------------------------------------------------ protocol v1

static std::vector<uint8_t> from_hex(const char* s) {
  std::vector<uint8_t> out;
  while (*s) {
    while (*s == ' ') ++s;
    if (!*s) break;
    out.push_back(static_cast<uint8_t>(strtoul(std::string(s, 2).c_str(), nullptr, 16)));
    s += 2;
  }
  return out;
}

static void worked_example_values(uint16_t v[44]) {
  for (int i = 0; i < 19; ++i) v[i] = static_cast<uint16_t>(3000 + i);
  v[19] = 2450;
  for (int i = 20; i < 42; ++i) v[i] = 2048;
  v[42] = 2700;
  v[43] = 2040;
}

TEST(crc_check_values) {
  const char* digits = "123456789";
  CHECK(proto::crc16_ccitt_false(reinterpret_cast<const uint8_t*>(digits), 9) == 0x29B1);
  const uint8_t four[4] = {0x02, 0x03, 0x01, 0x2C};
  CHECK(proto::crc16_ccitt_false(four, 4) == 0xE627);
}

TEST(binary_frame_matches_worked_example) {
  // docs/tactile_protocol.md, "Worked example": finger 2, seq 259.
  std::string hex =
      "aa 55 02 03 01 2c "
      "b8 0b b9 0b ba 0b bb 0b bc 0b bd 0b be 0b bf 0b c0 0b c1 0b c2 0b c3 0b "
      "c4 0b c5 0b c6 0b c7 0b c8 0b c9 0b ca 0b 92 09 ";
  for (int i = 0; i < 22; ++i) hex += "00 08 ";
  hex += "8c 0a f8 07 a6 15";
  const std::vector<uint8_t> expected = from_hex(hex.c_str());
  CHECK(expected.size() == 96);
  uint16_t v[44];
  worked_example_values(v);
  uint8_t out[96];
  proto::build_binary(2, 259, v, out);
  CHECK(memcmp(out, expected.data(), 96) == 0);
  CHECK(proto::crc16_ccitt_false(out + 2, 92) == 0x15A6);
}

TEST(text_frame_matches_worked_example) {
  uint16_t v[44];
  worked_example_values(v);
  std::string expected = "F2,259";
  for (int i = 0; i < 44; ++i) expected += "," + std::to_string(v[i]);
  expected += "\n";
  char buf[proto::kTextFrameMax];
  const size_t n = proto::build_text(2, 259, v, buf, sizeof(buf));
  CHECK(std::string(buf, n) == expected);
  // Longest possible line fits.
  uint16_t big[44];
  for (int i = 0; i < 44; ++i) big[i] = 4095;
  CHECK(proto::build_text(255, 65535, big, buf, sizeof(buf)) == 231);
  CHECK(proto::build_text(255, 65535, big, buf, 100) == 0);
}

TEST(values_saturate_never_wrap) {
  uint16_t v[44] = {};
  v[0] = 5000;
  v[43] = 0xFFFF;
  uint8_t out[96];
  proto::build_binary(0, 0, v, out);
  CHECK((out[6] | (out[7] << 8)) == 4095);
  CHECK((out[92] | (out[93] << 8)) == 4095);
  char buf[proto::kTextFrameMax];
  const size_t n = proto::build_text(0, 0, v, buf, sizeof(buf));
  CHECK(std::string(buf, n).rfind(",4095\n") == n - 6);
}

// ------------------------------------------------------------------ sampler + bridge

// An SPI bus of simulated BioTacs, optionally corrupting chosen replies.
class SimBus final : public hal::SpiBus {
 public:
  explicit SimBus(std::vector<sim::SimBioTac>& s) : sims(s) {}
  void select(size_t s) override { sel = s, sims[s].chip_select(true); }
  void deselect(size_t s) override { sims[s].chip_select(false); }
  uint16_t transfer16(uint16_t mosi) override {
    uint16_t miso = sims[sel].transfer16(mosi);
    if (mosi == 0 && corrupt_read == reads) miso = static_cast<uint16_t>(miso ^ 0x0100);
    if (mosi == 0) ++reads;
    words.push_back(mosi);
    return miso;
  }
  uint8_t transfer8(uint8_t mosi) override { return sims[sel].transfer8(mosi); }
  void delay_us(uint32_t) override {}
  std::vector<sim::SimBioTac>& sims;
  size_t sel = 0;
  long reads = 0;
  long corrupt_read = -1;
  std::vector<uint16_t> words;
};

class MemSink final : public hal::ByteSink {
 public:
  size_t writable() override { return room; }
  size_t write(const uint8_t* d, size_t n) override {
    if (n > room) n = room;
    bytes.insert(bytes.end(), d, d + n);
    room -= n;
    return n;
  }
  size_t room = 1u << 30;
  std::vector<uint8_t> bytes;
};

struct Parsed {
  int frames = 0;
  int bad = 0;
  std::vector<std::pair<int, int>> finger_seq;
  size_t other_bytes = 0;
};

// A strict parser of a byte stream: '#' lines and binary frames only.
static Parsed parse_stream(const std::vector<uint8_t>& b) {
  Parsed p;
  size_t i = 0;
  while (i < b.size()) {
    if (b[i] == '#') {
      while (i < b.size() && b[i] != '\n') ++i;
      ++i;
      continue;
    }
    if (b[i] == 0xAA && i + 96 <= b.size() && b[i + 1] == 0x55 && b[i + 5] == 44) {
      const uint16_t crc = static_cast<uint16_t>(b[i + 94] | (b[i + 95] << 8));
      if (proto::crc16_ccitt_false(&b[i + 2], 92) == crc) {
        ++p.frames;
        p.finger_seq.emplace_back(b[i + 2], b[i + 3] | (b[i + 4] << 8));
      } else {
        ++p.bad;
      }
      i += 96;
      continue;
    }
    ++p.other_bytes;
    ++i;
  }
  return p;
}

TEST(probe_reads_serial_and_firmware_and_names_absent) {
  std::vector<sim::SimBioTac> sims;
  sims.emplace_back(0, true);
  sims.emplace_back(1, false);
  SimBus bus(sims);
  const bridge::SensorInfo a = bridge::probe_sensor(bus, 0);
  const bridge::SensorInfo b = bridge::probe_sensor(bus, 1);
  CHECK(a.present && strcmp(a.serial, "BT-SIM-0000") == 0 && strcmp(a.firmware, "sim-1.0") == 0);
  CHECK(!b.present && b.serial[0] == '\0');
  // The read command is 0x61 followed by the property byte.
  CHECK(bus.words.size() >= 2 && bus.words[0] == 0x6115 && bus.words[1] == 0x6113);
  MemSink sink;
  const uint8_t ids[2] = {4, 7};
  bridge::Bridge br(sink, ids, 2, bridge::Mode::kBinary);
  const bridge::SensorInfo infos[2] = {a, b};
  br.queue_info(infos, 4400000);
  const std::string text(sink.bytes.begin(), sink.bytes.end());
  CHECK(text.find("# biotac_bridge ") == 0);
  CHECK(text.find("# finger 4 (sensor 0): BioTac serial BT-SIM-0000, firmware sim-1.0\n") != std::string::npos);
  CHECK(text.find("# finger 7 (sensor 1): no answer") != std::string::npos);
  CHECK(text.find('F') == std::string::npos);  // nothing a text-mode reader could take for a frame
}

// Runs two frames of 3 simulated sensors; returns the frames and checks the SPI words.
static std::vector<bridge::Sampler::Frame> two_frames(bridge::ReadTiming timing, int expected_ticks) {
  std::vector<sim::SimBioTac> sims;
  for (unsigned s = 0; s < 3; ++s) sims.emplace_back(s, true);
  SimBus bus(sims);
  bridge::Sampler sampler(bus, 3, timing);
  std::vector<bridge::Sampler::Frame> frames;
  int ticks = 0;
  bridge::Sampler::Frame f{};
  while (frames.size() < 2) {
    ++ticks;
    if (sampler.tick()) {
      CHECK(sampler.take(f));
      CHECK(!sampler.take(f));
      frames.push_back(f);
      for (size_t s = 0; s < 3; ++s) {
        CHECK(f.seq[s] == frames.size() - 1);
        CHECK(f.bad[s] == 0);
        for (size_t i = 0; i < 44; ++i) CHECK(f.values[s][i] > 0 && f.values[s][i] <= 4095);
      }
    }
  }
  CHECK(ticks == expected_ticks);
  // Commands go out per position, to every sensor, in the standard order; each
  // command is read back (MOSI 0x0000) once.
  std::vector<uint16_t> cmds;
  size_t reads = 0;
  for (uint16_t w : bus.words) {
    if (w != 0) {
      cmds.push_back(w);
    } else {
      ++reads;
    }
  }
  CHECK(cmds.size() == 3u * static_cast<size_t>(ticks));
  CHECK(reads == 3u * 88u);
  for (size_t t = 0; t < static_cast<size_t>(ticks); ++t)
    for (size_t s = 0; s < 3; ++s) CHECK(cmds[3 * t + s] == bt::sampling_word(bt::frame_channel(t % 44)));
  if (timing == bridge::ReadTiming::kSameTick) {  // per tick: 3 commands, then 3 reads
    for (size_t t = 0; t < 88; ++t)
      for (size_t k = 0; k < 6; ++k) CHECK((bus.words[6 * t + k] == 0) == (k >= 3));
  }
  CHECK(sampler.bad_replies() == 0);
  return frames;
}

TEST(sampler_sends_the_standard_sequence_and_builds_frames) {
  const auto same = two_frames(bridge::ReadTiming::kSameTick, 88);
  const auto next = two_frames(bridge::ReadTiming::kNextTick, 89);  // last reply read on tick 45
  for (size_t k = 0; k < 2; ++k) CHECK(memcmp(same[k].values, next[k].values, sizeof(same[k].values)) == 0);
}

TEST(bad_parity_holds_the_value_and_silent_sensor_is_not_sent) {
  std::vector<sim::SimBioTac> sims;
  sims.emplace_back(0, true);
  sims.emplace_back(1, false);  // nothing on this chip-select
  SimBus bus(sims);
  bus.corrupt_read = 44 * 2 + 2 * 3;  // sensor 0, position 3 (PAC) of the second frame
  bridge::Sampler sampler(bus, 2);
  MemSink sink;
  const uint8_t ids[2] = {0, 1};
  bridge::Bridge br(sink, ids, 2, bridge::Mode::kBinary);
  bridge::Sampler::Frame f{};
  bridge::Sampler::Frame first{};
  for (int k = 0; k < 3; ++k) {
    while (!sampler.tick()) {
    }
    CHECK(sampler.take(f));
    if (k == 0) first = f;
    CHECK(f.bad[1] == 44);
    CHECK(f.bad[0] == (k == 1 ? 1 : 0));
    br.push_frame(f);
  }
  CHECK(sampler.bad_replies() == 3 * 44 + 1);
  CHECK(br.stats().dropped_silent == 3);
  CHECK(br.stats().frames_sent == 3);
  const Parsed p = parse_stream(sink.bytes);
  CHECK(p.frames == 3 && p.bad == 0 && p.other_bytes == 0);
  for (const auto& fs : p.finger_seq) CHECK(fs.first == 0);
}

TEST(overrun_drops_the_frame_and_seq_shows_it) {
  std::vector<sim::SimBioTac> sims;
  sims.emplace_back(0, true);
  SimBus bus(sims);
  bridge::Sampler sampler(bus, 1);
  int completed = 0;
  while (completed < 3) completed += sampler.tick() ? 1 : 0;  // nobody takes frames 1 and 2
  bridge::Sampler::Frame f{};
  CHECK(sampler.take(f));
  CHECK(f.seq[0] == 0);  // the mailbox kept the first; the two later ones were dropped
  CHECK(sampler.overruns() == 2);
  while (!sampler.tick()) {
  }
  CHECK(sampler.take(f));
  CHECK(f.seq[0] == 3);
}

TEST(link_never_blocks_and_frames_stay_whole) {
  std::vector<sim::SimBioTac> sims;
  for (unsigned s = 0; s < 4; ++s) sims.emplace_back(s, true);
  SimBus bus(sims);
  bridge::Sampler sampler(bus, 4);
  MemSink sink;
  sink.room = 1000;  // the host reads 1000 bytes, then stops reading
  const uint8_t ids[4] = {0, 1, 2, 3};
  bridge::Bridge br(sink, ids, 4, bridge::Mode::kBinary);
  bridge::Sampler::Frame f{};
  for (int k = 0; k < 40; ++k) {
    while (!sampler.tick()) {
    }
    CHECK(sampler.take(f));
    br.push_frame(f);  // returns at once even though the link takes nothing
    if (k == 29) sink.room = 1u << 20;  // the host reads again
  }
  br.pump();
  const bridge::Stats& st = br.stats();
  CHECK(st.frames_built == 160);
  CHECK(st.dropped_link > 0);
  CHECK(st.frames_sent + st.dropped_link == 160);
  CHECK(br.queued() == 0);
  const Parsed p = parse_stream(sink.bytes);
  CHECK(p.bad == 0 && p.other_bytes == 0);
  CHECK(p.frames == static_cast<int>(st.frames_sent));
  // Per finger the seq runs 0.. with one forward gap (the dropped frames), never backwards.
  for (int finger = 0; finger < 4; ++finger) {
    int last = -1, gaps = 0, n = 0;
    for (const auto& fs : p.finger_seq) {
      if (fs.first != finger) continue;
      ++n;
      CHECK(fs.second > last);
      if (last >= 0 && fs.second != last + 1) ++gaps;
      last = fs.second;
    }
    CHECK(gaps == 1);
    CHECK(last == 39);
    CHECK(n < 40);
  }
}

TEST(host_commands_switch_mode_and_report) {
  MemSink sink;
  const uint8_t ids[1] = {2};
  bridge::Bridge br(sink, ids, 1, bridge::Mode::kBinary);
  bridge::SensorInfo info{};
  CHECK(br.on_host_byte('t', &info, 4400000, 0, 0));
  CHECK(br.mode() == bridge::Mode::kText);
  bridge::Sampler::Frame f{};
  worked_example_values(f.values[0]);
  f.seq[0] = 259;
  br.push_frame(f);
  std::string text(sink.bytes.begin(), sink.bytes.end());
  CHECK(text.rfind("F2,259,3000,3001,", 0) == 0);
  CHECK(br.on_host_byte('b', &info, 4400000, 0, 0));
  CHECK(br.mode() == bridge::Mode::kBinary);
  sink.bytes.clear();
  CHECK(br.on_host_byte('s', &info, 4400000, 5, 6));
  text.assign(sink.bytes.begin(), sink.bytes.end());
  CHECK(text.rfind("# stats: built 1 sent 1 dropped_link 0 dropped_overrun 5 dropped_silent 0 bad_replies 6\n", 0) == 0);
  CHECK(!br.on_host_byte('x', &info, 4400000, 0, 0));
}

int main() {
  RUN(command_words_match_documentation);
  RUN(every_sampling_command_has_odd_parity);
  RUN(reply_layout_round_trip_and_parity);
  RUN(standard_frame_sequence);
  RUN(crc_check_values);
  RUN(binary_frame_matches_worked_example);
  RUN(text_frame_matches_worked_example);
  RUN(values_saturate_never_wrap);
  RUN(probe_reads_serial_and_firmware_and_names_absent);
  RUN(sampler_sends_the_standard_sequence_and_builds_frames);
  RUN(bad_parity_holds_the_value_and_silent_sensor_is_not_sent);
  RUN(overrun_drops_the_frame_and_seq_shows_it);
  RUN(link_never_blocks_and_frames_stay_whole);
  RUN(host_commands_switch_mode_and_report);
  printf("all %d tests passed (%d checks)\n", g_tests, g_checks);
  return 0;
}
