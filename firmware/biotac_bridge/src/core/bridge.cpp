#include "bridge.h"

#include <atomic>
#include <stdio.h>
#include <string.h>

namespace bridge {

size_t read_property(hal::SpiBus& spi, size_t sensor, uint8_t property, char* out, size_t cap) {
  spi.select(sensor);
  spi.transfer16(static_cast<uint16_t>((bt::kReadCommand << 8) | property));
  spi.deselect(sensor);
  spi.delay_us(bt::kAfterSampleDelayUs);
  size_t n = 0;
  // The answer ends with '\0' (or 0xFF: nobody drives MISO, the pull-up wins).
  for (size_t i = 0; i < 2 * kPropertyMax; ++i) {
    spi.select(sensor);
    const uint8_t b = spi.transfer8(0x00);
    spi.deselect(sensor);
    spi.delay_us(bt::kInterWordDelayUs);
    if (b == 0x00 || b == 0xFF) break;
    if (n < cap) out[n++] = (b >= 0x20 && b < 0x7F) ? static_cast<char>(b) : '?';
  }
  if (cap > 0) out[n < cap ? n : cap - 1] = '\0';
  return n;
}

SensorInfo probe_sensor(hal::SpiBus& spi, size_t sensor) {
  SensorInfo info{};
  read_property(spi, sensor, bt::kPropSerialNumber, info.serial, kPropertyMax + 1);
  read_property(spi, sensor, bt::kPropFirmwareVersion, info.firmware, kPropertyMax + 1);
  info.present = info.serial[0] == 'B' && info.serial[1] == 'T';
  return info;
}

// ---------------------------------------------------------------------- Sampler

Sampler::Sampler(hal::SpiBus& spi, size_t n_sensors, ReadTiming timing)
    : spi_(spi), n_(n_sensors > kMaxSensors ? kMaxSensors : n_sensors), timing_(timing) {}

void Sampler::send_commands(size_t pos) {
  const uint16_t word = bt::sampling_word(bt::frame_channel(pos));
  for (size_t s = 0; s < n_; ++s) {
    spi_.select(s);
    spi_.transfer16(word);
    spi_.deselect(s);
  }
}

bool Sampler::read_replies(size_t pos) {
  const size_t idx = bt::protocol_index(pos);
  for (size_t s = 0; s < n_; ++s) {
    spi_.select(s);
    const bt::Reply r = bt::decode_reply(spi_.transfer16(0x0000));
    spi_.deselect(s);
    if (r.parity_ok) {
      held_[s][idx] = r.value;
    } else {
      ++work_bad_[s];
      bad_replies_ = bad_replies_ + 1;
    }
    work_[s][idx] = held_[s][idx];  // a bad reply repeats the channel's last good value
  }
  if (pos != bt::kFrameSamples - 1) return false;
  if (box_full_) {
    overruns_ = overruns_ + 1;  // the main loop has not taken the last one: drop
  } else {
    memcpy(box_.values, work_, sizeof(work_));
    memcpy(box_.bad, work_bad_, sizeof(work_bad_));
    for (size_t s = 0; s < n_; ++s) box_.seq[s] = next_seq_[s];
    std::atomic_signal_fence(std::memory_order_release);
    box_full_ = true;
  }
  for (size_t s = 0; s < n_; ++s) {
    next_seq_[s] = static_cast<uint16_t>(next_seq_[s] + 1);
    work_bad_[s] = 0;
  }
  return true;
}

bool Sampler::tick() {
  bool completed = false;
  if (timing_ == ReadTiming::kSameTick) {
    send_commands(pos_);
    spi_.delay_us(bt::kAfterSampleDelayUs);
    completed = read_replies(pos_);
  } else {
    if (outstanding_) {
      completed = read_replies(last_pos_);
      spi_.delay_us(bt::kInterWordDelayUs);
    }
    send_commands(pos_);
    outstanding_ = true;
    last_pos_ = pos_;
  }
  pos_ = (pos_ + 1) % bt::kFrameSamples;
  return completed;
}

bool Sampler::take(Frame& out) {
  if (!box_full_) return false;
  std::atomic_signal_fence(std::memory_order_acquire);
  memcpy(&out, &box_, sizeof(Frame));
  std::atomic_signal_fence(std::memory_order_release);
  box_full_ = false;
  return true;
}

// ---------------------------------------------------------------------- Bridge

Bridge::Bridge(hal::ByteSink& link, const uint8_t* finger_ids, size_t n_sensors, Mode mode)
    : link_(link), n_(n_sensors > kMaxSensors ? kMaxSensors : n_sensors), mode_(mode) {
  for (size_t s = 0; s < n_; ++s) ids_[s] = finger_ids[s];
}

bool Bridge::enqueue(const uint8_t* data, size_t n) {
  if (n > kQueueBytes - count_) return false;
  size_t tail = (head_ + count_) % kQueueBytes;
  for (size_t i = 0; i < n; ++i) {
    queue_[tail] = data[i];
    tail = (tail + 1) % kQueueBytes;
  }
  count_ += n;
  return true;
}

void Bridge::discard_queued() {
  stats_.discarded_bytes += static_cast<uint32_t>(count_);
  head_ = 0;
  count_ = 0;
}

void Bridge::pump() {
  while (count_ > 0) {
    const size_t room = link_.writable();
    if (room == 0) return;
    size_t chunk = kQueueBytes - head_;  // contiguous part
    if (chunk > count_) chunk = count_;
    if (chunk > room) chunk = room;
    const size_t took = link_.write(queue_ + head_, chunk);
    if (took == 0) return;
    head_ = (head_ + took) % kQueueBytes;
    count_ -= took;
  }
}

void Bridge::push_frame(const Sampler::Frame& frame) {
  for (size_t s = 0; s < n_; ++s) {
    ++stats_.frames_built;
    if (frame.bad[s] >= proto::kValues) {  // nothing answered: send nothing, the host faults it
      ++stats_.dropped_silent;
      continue;
    }
    bool ok;
    if (mode_ == Mode::kBinary) {
      uint8_t buf[proto::kBinaryFrameBytes];
      proto::build_binary(ids_[s], frame.seq[s], frame.values[s], buf);
      ok = enqueue(buf, sizeof(buf));
    } else {
      char buf[proto::kTextFrameMax];
      const size_t n = proto::build_text(ids_[s], frame.seq[s], frame.values[s], buf, sizeof(buf));
      ok = enqueue(reinterpret_cast<const uint8_t*>(buf), n);
    }
    if (ok) {
      ++stats_.frames_sent;
    } else {
      ++stats_.dropped_link;
    }
  }
  pump();
}

bool Bridge::queue_line(const char* text) {
  char line[160];
  const int n = snprintf(line, sizeof(line), "# %s\n", text);
  if (n <= 0) return false;
  size_t len = static_cast<size_t>(n);
  if (len >= sizeof(line)) {  // truncated: keep the line end
    len = sizeof(line) - 1;
    line[len - 1] = '\n';
  }
  const bool ok = enqueue(reinterpret_cast<const uint8_t*>(line), len);
  pump();
  return ok;
}

void Bridge::queue_info(const SensorInfo* infos, uint32_t spi_clock_hz) {
  char text[140];
  snprintf(text, sizeof(text),
           "biotac_bridge %s: protocol v1 %s, %u sensors, %u samples/s, %u-sample frames, spi %u kHz",
           kVersion, mode_ == Mode::kBinary ? "binary" : "text", static_cast<unsigned>(n_),
           static_cast<unsigned>(bt::kSampleRateHz), static_cast<unsigned>(bt::kFrameSamples),
           static_cast<unsigned>(spi_clock_hz / 1000));
  queue_line(text);
  for (size_t s = 0; s < n_; ++s) {
    if (infos[s].present) {
      snprintf(text, sizeof(text), "finger %u (sensor %u): BioTac serial %s, firmware %s",
               static_cast<unsigned>(ids_[s]), static_cast<unsigned>(s), infos[s].serial, infos[s].firmware);
    } else {
      snprintf(text, sizeof(text),
               "finger %u (sensor %u): no answer (no BioTac on this chip-select?); its frames are not sent",
               static_cast<unsigned>(ids_[s]), static_cast<unsigned>(s));
    }
    queue_line(text);
  }
}

void Bridge::queue_stats(uint32_t overruns, uint32_t bad_replies) {
  char text[140];
  snprintf(text, sizeof(text),
           "stats: built %lu sent %lu dropped_link %lu dropped_overrun %lu dropped_silent %lu bad_replies %lu",
           static_cast<unsigned long>(stats_.frames_built), static_cast<unsigned long>(stats_.frames_sent),
           static_cast<unsigned long>(stats_.dropped_link), static_cast<unsigned long>(overruns),
           static_cast<unsigned long>(stats_.dropped_silent), static_cast<unsigned long>(bad_replies));
  queue_line(text);
}

bool Bridge::on_host_byte(uint8_t c, const SensorInfo* infos, uint32_t spi_clock_hz, uint32_t overruns,
                          uint32_t bad_replies) {
  switch (c) {
    case 'b':
      mode_ = Mode::kBinary;
      return true;
    case 't':
      mode_ = Mode::kText;
      return true;
    case 'i':
      queue_info(infos, spi_clock_hz);
      return true;
    case 's':
      queue_stats(overruns, bad_replies);
      return true;
    default:
      return false;
  }
}

}  // namespace bridge
