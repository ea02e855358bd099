// The bridge logic shared by the Teensy and the host build.
//
// Sampler (runs in the 4.4 kHz timer interrupt on the Teensy): each tick samples one
// position of the standard 44-sample frame on every sensor. Two read timings:
//  - ReadTiming::kSameTick (default; the sequence of SynTouch's reference code): send
//    every sensor the sampling command, wait the 50 us after-sample delay, then read
//    every sensor's reply. About 50 us + 2 transfers per sensor of each 227 us tick.
//  - ReadTiming::kNextTick: read the reply of the previous tick's command, then send the
//    next command; no busy wait, but it relies on the BioTac keeping its reply for one
//    tick (227 us), which SynTouch's documentation does not state. Try it on hardware
//    only if the interrupt load of kSameTick is a problem.
// When a frame is complete it is handed to the main loop through a one-frame mailbox;
// if the main loop has not taken the previous one yet the frame is dropped (counted),
// its seq still used.
//
// Bridge (runs in the main loop): turns complete frames into protocol v1 frames,
// queues them whole in a byte queue and pumps the queue into the link as far as the
// link takes bytes without blocking. A frame that does not fit in the queue is
// dropped; seq numbers count every frame, so the host sees the gap.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "biotac_spi.h"
#include "hal.h"
#include "protocol_v1.h"

namespace bridge {

constexpr size_t kMaxSensors = 8;
constexpr size_t kPropertyMax = 32;  // longest property string kept (serial number: 16)
constexpr size_t kQueueBytes = 2048;
constexpr const char* kVersion = "1.0.0";

enum class Mode : uint8_t { kBinary, kText };
enum class ReadTiming : uint8_t { kSameTick, kNextTick };

struct SensorInfo {
  char serial[kPropertyMax + 1];
  char firmware[kPropertyMax + 1];
  bool present;  // the serial number read back starts with "BT"
};

struct Stats {
  uint32_t frames_built = 0;     // frames completed by the sampler, all sensors
  uint32_t frames_sent = 0;      // frames queued for the link
  uint32_t dropped_link = 0;     // frames dropped: the link/queue had no room
  uint32_t dropped_silent = 0;   // frames dropped: every reply of the frame was bad
  uint32_t discarded_bytes = 0;  // queued bytes forgotten by discard_queued()
};

// Reads a property string (read command + property byte, then one byte per transfer).
size_t read_property(hal::SpiBus& spi, size_t sensor, uint8_t property, char* out, size_t cap);

// Reads serial number and firmware version of one sensor.
SensorInfo probe_sensor(hal::SpiBus& spi, size_t sensor);

class Sampler {
 public:
  Sampler(hal::SpiBus& spi, size_t n_sensors, ReadTiming timing = ReadTiming::kSameTick);

  // One 4.4 kHz tick. Returns true when this tick completed a frame.
  bool tick();

  // Main loop side of the mailbox: copies the newest complete frame and returns
  // true, or returns false when there is none.
  struct Frame {
    uint16_t values[kMaxSensors][proto::kValues];  // protocol order
    uint16_t seq[kMaxSensors];
    uint8_t bad[kMaxSensors];                        // bad replies in this frame
  };
  bool take(Frame& out);

  size_t n_sensors() const { return n_; }
  uint32_t overruns() const { return overruns_; }
  uint32_t bad_replies() const { return bad_replies_; }

 private:
  void send_commands(size_t pos);
  bool read_replies(size_t pos);  // true when pos completed a frame

  hal::SpiBus& spi_;
  size_t n_;
  ReadTiming timing_;
  size_t pos_ = 0;             // frame position of the next command
  bool outstanding_ = false;   // a command was sent on the previous tick
  size_t last_pos_ = 0;        // its frame position
  uint16_t work_[kMaxSensors][proto::kValues] = {};
  uint8_t work_bad_[kMaxSensors] = {};
  uint16_t held_[kMaxSensors][proto::kValues] = {};  // last good value per channel
  uint16_t next_seq_[kMaxSensors] = {};
  Frame box_ = {};
  volatile bool box_full_ = false;
  volatile uint32_t overruns_ = 0;
  volatile uint32_t bad_replies_ = 0;
};

class Bridge {
 public:
  // finger_ids[i]: the protocol finger number of sensor i (the hand file's sensor_id).
  Bridge(hal::ByteSink& link, const uint8_t* finger_ids, size_t n_sensors, Mode mode);

  // Queues one complete sampler frame (a frame that does not fit is dropped).
  void push_frame(const Sampler::Frame& frame);
  // Moves queued bytes into the link, as many as it takes now.
  void pump();

  // Forgets every queued byte (stale frames), e.g. when a host opens the port.
  void discard_queued();

  // Queues a '#' info line (whole, or not at all). Returns false if it did not fit.
  bool queue_line(const char* text);
  // Queues the start-up report: a header line and one line per sensor.
  void queue_info(const SensorInfo* infos, uint32_t spi_clock_hz);
  // Queues a statistics line.
  void queue_stats(uint32_t overruns, uint32_t bad_replies);

  // A byte from the host: 'b' binary mode, 't' text mode, 'i' info again, 's' stats.
  // Returns true if the byte was a command.
  bool on_host_byte(uint8_t c, const SensorInfo* infos, uint32_t spi_clock_hz, uint32_t overruns,
                    uint32_t bad_replies);

  Mode mode() const { return mode_; }
  void set_mode(Mode m) { mode_ = m; }
  const Stats& stats() const { return stats_; }
  size_t queued() const { return count_; }

 private:
  bool enqueue(const uint8_t* data, size_t n);

  hal::ByteSink& link_;
  uint8_t ids_[kMaxSensors] = {};
  size_t n_;
  Mode mode_;
  Stats stats_;
  uint8_t queue_[kQueueBytes] = {};
  size_t head_ = 0;  // next byte to send
  size_t count_ = 0;
};

}  // namespace bridge
