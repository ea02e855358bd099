// bridge_host: the bridge logic of the firmware, run on a computer against simulated
// BioTacs. Only the hardware layer differs from the Teensy build: SPI goes to
// SimBioTac peers, the 4.4 kHz timer is replaced by running the 44 ticks of one frame
// every 10 ms, and the USB link is standard output or a pseudo-terminal.
//
//   bridge_host --fingers N --samples S [--text] [--trace-spi FILE] [--absent LIST] [--read-next-tick]
//       S frames per fingertip (fingers 0..N-1) to standard output, as fast as possible.
//   bridge_host --pty --fingers N --seconds T [--text] [--absent LIST]
//       real time, 100 Hz per fingertip, on a pseudo-terminal whose path is printed
//       as the first line of standard output.
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <string>
#include <vector>

#include "../core/bridge.h"
#include "sim_biotac.h"

namespace {

volatile sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

class HostSpi final : public hal::SpiBus {
 public:
  HostSpi(std::vector<sim::SimBioTac>& sims, FILE* trace) : sims_(sims), trace_(trace) {}
  void select(size_t s) override {
    sel_ = s;
    sims_[s].chip_select(true);
  }
  void deselect(size_t s) override { sims_[s].chip_select(false); }
  uint16_t transfer16(uint16_t mosi) override {
    const uint16_t miso = sims_[sel_].transfer16(mosi);
    if (trace_) fprintf(trace_, "%zu %04x %04x\n", sel_, mosi, miso);
    return miso;
  }
  uint8_t transfer8(uint8_t mosi) override {
    const uint8_t miso = sims_[sel_].transfer8(mosi);
    if (trace_) fprintf(trace_, "# %zu %02x %02x\n", sel_, mosi, miso);  // 8-bit transfer
    return miso;
  }
  void delay_us(uint32_t) override {}  // the simulated sensors keep time by samples

 private:
  std::vector<sim::SimBioTac>& sims_;
  FILE* trace_;
  size_t sel_ = 0;
};

// Standard output: every byte is written (blocking), so a file or pipe gets all frames.
class StdoutSink final : public hal::ByteSink {
 public:
  size_t writable() override { return 1u << 20; }
  size_t write(const uint8_t* data, size_t n) override {
    size_t done = 0;
    while (done < n) {
      const ssize_t w = ::write(STDOUT_FILENO, data + done, n - done);
      if (w < 0) {
        if (errno == EINTR) continue;
        return done;
      }
      done += static_cast<size_t>(w);
    }
    return done;
  }
};

// Pseudo-terminal master, non-blocking: takes what fits, never waits. Like a USB
// CDC port without a host, it takes nothing while no program has the pty open (the
// master reports a hang-up then), which plays the part of the Teensy's DTR line.
class PtySink final : public hal::ByteSink {
 public:
  explicit PtySink(int fd) : fd_(fd) {}
  bool host_open() {
    pollfd p{fd_, POLLOUT, 0};
    return poll(&p, 1, 0) >= 0 && (p.revents & POLLHUP) == 0;
  }
  size_t writable() override { return open_ ? 4096 : 0; }
  size_t write(const uint8_t* data, size_t n) override {
    const ssize_t w = ::write(fd_, data, n);
    return w > 0 ? static_cast<size_t>(w) : 0;
  }
  bool open_ = false;

 private:
  int fd_;
};

void usage(FILE* f) {
  fprintf(f,
          "usage: bridge_host --fingers N (--samples S | --pty --seconds T) [--text]\n"
          "                   [--trace-spi FILE] [--absent I,J,...] [--read-next-tick]\n"
          "  --fingers N       simulated BioTacs, finger numbers 0..N-1 (1..%zu)\n"
          "  --samples S       write S frames per fingertip to standard output and exit\n"
          "  --pty             stream in real time (100 Hz) on a pseudo-terminal; its path\n"
          "                    is the first line on standard output\n"
          "  --seconds T       with --pty: stop after T seconds (default: until SIGINT/SIGTERM)\n"
          "  --text            protocol v1 text mode instead of binary\n"
          "  --trace-spi FILE  one line per 16-bit SPI transfer: <sensor> <mosi hex> <miso hex>\n"
          "                    (8-bit start-up transfers as '# <sensor> <mosi> <miso>')\n"
          "  --absent LIST     these sensors do not answer (no BioTac on that chip-select)\n"
          "  --read-next-tick  read each reply on the next 4.4 kHz tick instead of 50 us after\n"
          "                    its command (see ReadTiming in src/core/bridge.h)\n",
          bridge::kMaxSensors);
}

bool parse_uint(const char* s, unsigned long max, unsigned long& out) {
  char* end = nullptr;
  errno = 0;
  const unsigned long v = strtoul(s, &end, 10);
  if (errno != 0 || end == s || *end != '\0' || v > max) return false;
  out = v;
  return true;
}

double now_s() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

void sleep_until(double t) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(t);
  ts.tv_nsec = static_cast<long>((t - static_cast<double>(ts.tv_sec)) * 1e9);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR && !g_stop) {
  }
}

// Runs ticks until a frame completes, hands it to the bridge.
void run_one_frame(bridge::Sampler& sampler, bridge::Bridge& br) {
  while (!sampler.tick()) {
  }
  bridge::Sampler::Frame frame;
  if (sampler.take(frame)) br.push_frame(frame);
}

}  // namespace

int main(int argc, char** argv) {
  unsigned long fingers = 0, samples = 0;
  double seconds = -1.0;
  bool pty = false, text = false, have_samples = false, next_tick = false;
  const char* trace_path = nullptr;
  std::vector<bool> absent(bridge::kMaxSensors, false);

  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--help" || a == "-h") {
      usage(stdout);
      return 0;
    } else if (a == "--fingers" && has_value) {
      if (!parse_uint(argv[++i], bridge::kMaxSensors, fingers) || fingers == 0) {
        fprintf(stderr, "bridge_host: --fingers must be 1..%zu\n", bridge::kMaxSensors);
        return 2;
      }
    } else if (a == "--samples" && has_value) {
      if (!parse_uint(argv[++i], 100000000ul, samples)) {
        fprintf(stderr, "bridge_host: bad --samples\n");
        return 2;
      }
      have_samples = true;
    } else if (a == "--seconds" && has_value) {
      char* end = nullptr;
      seconds = strtod(argv[++i], &end);
      if (end == argv[i] || *end != '\0' || !(seconds > 0.0)) {
        fprintf(stderr, "bridge_host: bad --seconds\n");
        return 2;
      }
    } else if (a == "--trace-spi" && has_value) {
      trace_path = argv[++i];
    } else if (a == "--absent" && has_value) {
      std::string list = argv[++i];
      size_t start = 0;
      while (start <= list.size()) {
        const size_t comma = list.find(',', start);
        const std::string item = list.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
        unsigned long idx = 0;
        if (!parse_uint(item.c_str(), bridge::kMaxSensors - 1, idx)) {
          fprintf(stderr, "bridge_host: bad --absent item '%s'\n", item.c_str());
          return 2;
        }
        absent[idx] = true;
        if (comma == std::string::npos) break;
        start = comma + 1;
      }
    } else if (a == "--pty") {
      pty = true;
    } else if (a == "--text") {
      text = true;
    } else if (a == "--read-next-tick") {
      next_tick = true;
    } else {
      fprintf(stderr, "bridge_host: unknown or incomplete option '%s'\n", a.c_str());
      usage(stderr);
      return 2;
    }
  }
  if (fingers == 0 || pty == have_samples) {
    usage(stderr);
    return 2;
  }

  FILE* trace = nullptr;
  if (trace_path) {
    trace = fopen(trace_path, "w");
    if (!trace) {
      fprintf(stderr, "bridge_host: cannot write %s: %s\n", trace_path, strerror(errno));
      return 1;
    }
  }

  std::vector<sim::SimBioTac> sims;
  for (unsigned s = 0; s < fingers; ++s) sims.emplace_back(s, !absent[s]);
  HostSpi spi(sims, trace);
  uint8_t ids[bridge::kMaxSensors];
  for (size_t s = 0; s < bridge::kMaxSensors; ++s) ids[s] = static_cast<uint8_t>(s);
  const bridge::Mode mode = text ? bridge::Mode::kText : bridge::Mode::kBinary;

  // Start-up: read each sensor's serial number and firmware version.
  bridge::SensorInfo infos[bridge::kMaxSensors] = {};
  for (size_t s = 0; s < fingers; ++s) {
    infos[s] = bridge::probe_sensor(spi, s);
    if (infos[s].present) {
      fprintf(stderr, "bridge_host: finger %zu: BioTac serial %s, firmware %s\n", s, infos[s].serial,
              infos[s].firmware);
    } else {
      fprintf(stderr, "bridge_host: finger %zu: no answer (no BioTac on this chip-select?)\n", s);
    }
  }
  bridge::Sampler sampler(spi, fingers, next_tick ? bridge::ReadTiming::kNextTick : bridge::ReadTiming::kSameTick);

  if (!pty) {
    StdoutSink out;
    bridge::Bridge br(out, ids, fingers, mode);
    br.queue_info(infos, bt::kSpiClockHz);
    for (unsigned long k = 0; k < samples; ++k) run_one_frame(sampler, br);
    br.pump();
    const bridge::Stats& st = br.stats();
    fprintf(stderr, "bridge_host: %lu frames per fingertip; sent %lu, dropped %lu (link) %lu (silent), bad replies %lu\n",
            samples, static_cast<unsigned long>(st.frames_sent), static_cast<unsigned long>(st.dropped_link),
            static_cast<unsigned long>(st.dropped_silent), static_cast<unsigned long>(sampler.bad_replies()));
    if (trace) fclose(trace);
    return 0;
  }

  // --pty: a raw pseudo-terminal. The slave end is opened once to make it raw, then
  // closed: a reader opening it is then seen as the hang-up on the master clearing.
  const int master = posix_openpt(O_RDWR | O_NOCTTY);
  if (master < 0 || grantpt(master) != 0 || unlockpt(master) != 0) {
    fprintf(stderr, "bridge_host: cannot open a pseudo-terminal: %s\n", strerror(errno));
    return 1;
  }
  const char* slave_path = ptsname(master);
  const int slave = slave_path ? open(slave_path, O_RDWR | O_NOCTTY) : -1;
  if (slave < 0) {
    fprintf(stderr, "bridge_host: cannot open the pty slave: %s\n", strerror(errno));
    return 1;
  }
  termios tio{};
  tcgetattr(slave, &tio);
  cfmakeraw(&tio);
  tcsetattr(slave, TCSANOW, &tio);
  close(slave);
  fcntl(master, F_SETFL, fcntl(master, F_GETFL) | O_NONBLOCK);
  signal(SIGINT, on_signal);
  signal(SIGTERM, on_signal);
  signal(SIGPIPE, SIG_IGN);
  printf("%s\n", slave_path);
  fflush(stdout);

  PtySink link(master);
  bridge::Bridge br(link, ids, fingers, mode);
  const double period = static_cast<double>(bt::kFrameSamples) / bt::kSampleRateHz;  // 10 ms
  const double t0 = now_s();
  double next = t0;
  unsigned long frames = 0;
  double opened_at = -1.0;
  while (!g_stop && (seconds < 0.0 || now_s() - t0 < seconds)) {
    // A host opened the port (held open for 20 ms, so that the input flush a serial
    // library does right after opening has passed; the Teensy's DTR test waits 15 ms):
    // drop the stale queue and send the start-up report first.
    if (!link.host_open()) {
      link.open_ = false;
      opened_at = -1.0;
    } else if (!link.open_) {
      if (opened_at < 0.0) opened_at = now_s();
      if (now_s() - opened_at >= 0.02) {
        link.open_ = true;
        br.discard_queued();
        br.queue_info(infos, bt::kSpiClockHz);
      }
    }
    run_one_frame(sampler, br);
    ++frames;
    uint8_t in[64];
    const ssize_t n = read(master, in, sizeof(in));  // commands from the host
    for (ssize_t k = 0; k < n; ++k)
      br.on_host_byte(in[k], infos, bt::kSpiClockHz, sampler.overruns(), sampler.bad_replies());
    next += period;
    const double now = now_s();
    if (now - next > 0.1) next = now;  // stalled far behind: do not burst
    sleep_until(next);
  }
  br.pump();
  const bridge::Stats& st = br.stats();
  fprintf(stderr,
          "bridge_host: %.2f s, %lu frames per fingertip; sent %lu, dropped %lu (link) %lu (silent), "
          "overruns %lu, bad replies %lu\n",
          now_s() - t0, frames, static_cast<unsigned long>(st.frames_sent),
          static_cast<unsigned long>(st.dropped_link), static_cast<unsigned long>(st.dropped_silent),
          static_cast<unsigned long>(sampler.overruns()), static_cast<unsigned long>(sampler.bad_replies()));
  close(master);
  if (trace) fclose(trace);
  return 0;
}
