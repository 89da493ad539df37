// jackson-firmware-posix: the firmware core as a Linux process.
//
// It creates a pseudo-terminal for the host link and prints "serial <path>" on stdout. Sensor
// values come as text lines on stdin (see docs/firmware.md, "Running the firmware on Linux"):
//
//   t <t_us> <enc_left> <enc_right> <imu_ok> <28 hex digits: MPU-6050 registers 0x3B..0x48>
//       set the sensors, advance the clock to t_us running every deadline on the way, reply
//   w <seq> <timeout_ms>
//       wait (wall clock) until the host's HEARTBEAT acknowledges telemetry SEQ, or a HELLO
//       starts a new session (whose host never acknowledges an older one's frame), then reply
//   s   reply only;   q   quit
//
// Each reply is one line:
//   s <t_us> <telemetry_seq|-1> <frames_sent> <heartbeat_ack|-1> <motor_left> <motor_right>
//     <braked> <failsafe> <session> <tx_dropped> <rx_crc_errors> <next_telemetry_us|-1>
//     <accel_fs> <gyro_fs> <motor_enable>
// where the last two are the MPU-6050 ranges of the firmware's driver (written to the chip at
// its next init, within one IMU period), which a simulator scales the registers it feeds by, and
// motor_enable is the recorded interlock line (1 asserted: host heartbeats live; 0 released:
// PCA9685 OE high / TB6612 STBY low), as the core last set it at or before t_us.
// With --realtime the clock follows CLOCK_MONOTONIC and t lines only update the sensors;
// --no-imu starts with the MPU-6050 absent (t lines may bring it later).
#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>

#include "advance.hpp"
#include "firmware.hpp"
#include "posix_hal.hpp"

using namespace jackson::fw;

namespace {

struct Options {
  bool realtime = false;
  bool motors = false;
  bool imu = true;
  std::string storage_dir;
  std::string link;
  uint32_t boot_id = 0;  ///< 0: draw one from std::random_device
};

[[noreturn]] void usage_error(const char* what) {
  std::fprintf(stderr,
               "jackson-firmware-posix: %s\nusage: jackson-firmware-posix [--realtime] "
               "[--motors] [--no-imu] [--storage DIR] [--link PATH] [--boot-id N]\n",
               what);
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--realtime") {
      o.realtime = true;
    } else if (a == "--motors") {
      o.motors = true;
    } else if (a == "--no-imu") {
      o.imu = false;
    } else if (a == "--storage" && i + 1 < argc) {
      o.storage_dir = argv[++i];
    } else if (a == "--link" && i + 1 < argc) {
      o.link = argv[++i];
    } else if (a == "--boot-id" && i + 1 < argc) {
      o.boot_id = static_cast<uint32_t>(std::strtoul(argv[++i], nullptr, 0));
    } else {
      usage_error(("unknown argument " + a).c_str());
    }
  }
  return o;
}

bool parse_hex14(const char* hex, std::array<uint8_t, 14>& out) {
  if (std::strlen(hex) != 28) return false;
  for (size_t i = 0; i < 14; ++i) {
    char byte[3] = {hex[2 * i], hex[2 * i + 1], 0};
    char* end = nullptr;
    out[i] = static_cast<uint8_t>(std::strtoul(byte, &end, 16));
    if (end != byte + 2) return false;
  }
  return true;
}

struct Process {
  posix::FeedClock clock;
  posix::FeedEncoders encoders;
  posix::FeedI2c i2c;
  posix::PtySerial serial;
  posix::FileStorage storage;
  posix::RecordedMotors motors;
  posix::RecordedMotorEnable motor_enable;
  Hal hal;
  Firmware fw;

  explicit Process(const Options& o)
      : storage(o.storage_dir),
        hal{clock, encoders, i2c,
            serial, storage, o.motors ? &motors : nullptr,
            o.boot_id != 0 ? o.boot_id : (std::random_device{}() | 1u), &motor_enable},
        fw(hal) {}

  // Runs tick() at every deadline of the core up to `t` (lockstep), then at `t` itself.
  void advance_to(uint64_t t) {
    posix::advance_before(fw, clock, t);
    fw.tick();
  }

  void reply() {
    uint8_t seq = 0;
    const bool sent = fw.last_telemetry_seq(seq);
    uint8_t hb = 0;
    const bool seen = fw.last_heartbeat_ack(hb);
    const long long next =
        fw.session_active() ? static_cast<long long>(fw.next_telemetry_us()) : -1;
    std::printf("s %llu %d %u %d %d %d %d %d %d %u %u %lld %u %u %d\n",
                static_cast<unsigned long long>(clock.now64()), sent ? seq : -1,
                fw.frames_sent(), seen ? hb : -1, motors.left_, motors.right_,
                motors.braked_ ? 1 : 0, fw.motors().failsafe ? 1 : 0, fw.session_active() ? 1 : 0,
                fw.tx_dropped(), fw.rx_counters().crc_errors, next, fw.imu().accel_fs(),
                fw.imu().gyro_fs(), motor_enable.enabled_ ? 1 : 0);
    std::fflush(stdout);
  }

  // Serves the host link on the wall clock until HEARTBEAT acknowledges `seq`, a new session
  // begins (no telemetry sent in it yet), or time runs out.
  void wait_heartbeat(int seq, int timeout_ms) {
    const uint64_t t = clock.now64();
    for (int waited = 0; waited <= timeout_ms;) {
      clock.set(t);
      fw.tick();
      uint8_t hb = 0;
      if (fw.last_heartbeat_ack(hb) && hb == seq) return;
      uint8_t sent_seq = 0;
      if (!fw.last_telemetry_seq(sent_seq)) return;  // a HELLO began a new session
      pollfd p{serial.fd(), POLLIN, 0};
      const int step = timeout_ms - waited < 5 ? timeout_ms - waited : 5;
      ::poll(&p, 1, step > 0 ? step : 1);
      waited += step > 0 ? step : 1;
    }
  }
};

}  // namespace

int main(int argc, char** argv) {
  const Options opt = parse(argc, argv);
  static Process p(opt);  // static: lives as long as the process, not on a small stack
  std::string path, error;
  if (!p.serial.open_pty(path, error)) {
    std::fprintf(stderr, "jackson-firmware-posix: %s\n", error.c_str());
    return 1;
  }
  if (!opt.link.empty()) {
    ::unlink(opt.link.c_str());
    if (::symlink(path.c_str(), opt.link.c_str()) != 0) {
      std::fprintf(stderr, "jackson-firmware-posix: cannot link %s: %s\n", opt.link.c_str(),
                   std::strerror(errno));
      return 1;
    }
  }
  p.clock.follow_monotonic(opt.realtime);
  p.i2c.set_present(opt.imu);
  p.fw.begin();
  std::printf("serial %s\n", path.c_str());
  std::fflush(stdout);

  char line[256];
  pollfd fds[2] = {{STDIN_FILENO, POLLIN, 0}, {p.serial.fd(), POLLIN, 0}};
  for (;;) {
    if (opt.realtime) {  // serve the link continuously; stdin only updates sensors
      ::poll(fds, 2, 1);
      p.fw.tick();
      if ((fds[0].revents & (POLLIN | POLLHUP)) == 0) continue;
    }
    if (std::fgets(line, sizeof line, stdin) == nullptr) break;
    if (line[0] == 'q') break;
    if (line[0] == 't') {
      unsigned long long t = 0;
      long long l = 0, r = 0;
      int imu_ok = 0;
      char hex[64] = {0};
      std::array<uint8_t, 14> regs{};
      if (std::sscanf(line, "t %llu %lld %lld %d %63s", &t, &l, &r, &imu_ok, hex) != 5 ||
          !parse_hex14(hex, regs)) {
        std::fprintf(stderr, "jackson-firmware-posix: bad feed line: %s", line);
        return 2;
      }
      p.encoders.set(l, r);
      p.i2c.set(imu_ok != 0, regs);
      if (!opt.realtime) p.advance_to(t);
      p.reply();
    } else if (line[0] == 'w') {
      int seq = 0, timeout_ms = 0;
      if (std::sscanf(line, "w %d %d", &seq, &timeout_ms) != 2) {
        std::fprintf(stderr, "jackson-firmware-posix: bad feed line: %s", line);
        return 2;
      }
      p.wait_heartbeat(seq, timeout_ms);
      p.reply();
    } else if (line[0] == 's') {
      p.reply();
    }
  }
  if (!opt.link.empty()) ::unlink(opt.link.c_str());
  return 0;
}
