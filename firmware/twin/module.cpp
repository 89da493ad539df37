// The firmware core as a Python extension module: the digital twin's MCU (sim/mcu.py).
//
// The same core the ESP32-S3 and the POSIX firmware run (firmware/core), behind a HAL made of
// the twin: the clock is the twin's (set from Python, every deadline on the way run in order),
// the PCNT counters present the twin's cumulative wheel counts, read through a Python callable
// the moment the core reads them, the MPU-6050 register file is the POSIX build's (fed from
// Python), the host link's bytes go out through a Python callable (which may drop a frame whole)
// and come in from a buffer, and the motor outputs and the interlock line are recorded. Built by
// `make setup` (tools/build_compiled.py) into build/compiled-firmware/<digest>/.
#include <pybind11/pybind11.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "advance.hpp"
#include "firmware.hpp"
#include "posix_hal.hpp"

namespace py = pybind11;
using namespace jackson::fw;

namespace {

/// The ESP32 PCNT in front of the twin's true cumulative counts: a 16-bit count that resets at
/// +-limit, plus the limit events (as posix::FeedEncoders), read when the core reads it.
class TwinEncoders : public Encoders {
 public:
  explicit TwinEncoders(py::object counts) : counts_(std::move(counts)) {}
  int16_t limit() const override { return posix::FeedEncoders::kLimit; }
  void read(PcntSample& left, PcntSample& right) override {
    const auto lr = counts_().cast<std::pair<int64_t, int64_t>>();
    split(lr.first, left);
    split(lr.second, right);
  }

 private:
  static void split(int64_t total, PcntSample& s) {
    const int64_t events = total / posix::FeedEncoders::kLimit;  // toward zero, as the counter
    s.limit_events = static_cast<int32_t>(events);
    s.count = static_cast<int16_t>(total - events * posix::FeedEncoders::kLimit);
  }
  py::object counts_;
};

/// The host link: frames out through a Python callable (true: on the line; false: no room, the
/// frame is dropped whole), bytes in from a buffer Python fills.
class TwinSerial : public SerialPort {
 public:
  explicit TwinSerial(py::object write) : write_(std::move(write)) {}
  bool write_all_or_nothing(const uint8_t* data, size_t n) override {
    return write_(py::bytes(reinterpret_cast<const char*>(data), n)).cast<bool>();
  }
  size_t read(uint8_t* out, size_t cap) override {
    const size_t n = std::min(cap, rx_.size() - pos_);
    std::memcpy(out, rx_.data() + pos_, n);
    pos_ += n;
    if (pos_ == rx_.size()) {
      rx_.clear();
      pos_ = 0;
    }
    return n;
  }
  void push(const std::string& data) { rx_.insert(rx_.end(), data.begin(), data.end()); }

 private:
  py::object write_;
  std::vector<uint8_t> rx_;
  size_t pos_ = 0;
};

/// One MCU: the HAL's parts and the core, booted at construction.
class Core {
 public:
  Core(py::object write, py::object counts, bool motor_output, bool imu_present, uint64_t boot_us,
       uint32_t boot_id)
      : encoders_(std::move(counts)),
        serial_(std::move(write)),
        storage_(""),
        hal_{clock_, encoders_, i2c_, serial_, storage_, motor_output ? &motors_ : nullptr,
             boot_id, &enable_},
        fw_(hal_) {
    clock_.set(boot_us);
    i2c_.set_present(imu_present);
    fw_.begin();
  }

  /// The MPU-6050 as the polls from now on read it: answering or not, registers 0x3B..0x48.
  void set_imu(bool answering, const std::string& burst) {
    std::array<uint8_t, 14> regs{};
    if (burst.size() != regs.size()) throw py::value_error("set_imu: 14 register bytes expected");
    std::memcpy(regs.data(), burst.data(), regs.size());
    i2c_.set(answering, regs);
  }

  /// Every deadline of the core before `t`, then the clock at `t` without a tick there.
  void advance_before(uint64_t t) { posix::advance_before(fw_, clock_, t); }

  void tick() { fw_.tick(); }
  void push(py::bytes data) { serial_.push(std::string(data)); }

  uint64_t now_us() { return clock_.now64(); }
  const Firmware& fw() const { return fw_; }
  const posix::RecordedMotors& motors() const { return motors_; }
  bool line() const { return enable_.enabled_; }

 private:
  posix::FeedClock clock_;
  TwinEncoders encoders_;
  posix::FeedI2c i2c_;
  TwinSerial serial_;
  posix::FileStorage storage_;
  posix::RecordedMotors motors_;
  posix::RecordedMotorEnable enable_;
  Hal hal_;
  Firmware fw_;
};

py::object optional_seq(bool valid, uint8_t seq) {
  return valid ? py::object(py::int_(seq)) : py::object(py::none());
}

}  // namespace

PYBIND11_MODULE(jackson_firmware_core, m) {
  m.doc() = "The firmware core (firmware/core) with the digital twin as its HAL.";
  m.attr("PCNT_LIMIT") = posix::FeedEncoders::kLimit;
  m.attr("FIRMWARE_VERSION") =
      py::make_tuple(kFirmwareVersion[0], kFirmwareVersion[1], kFirmwareVersion[2]);
  py::class_<Core>(m, "Core")
      .def(py::init<py::object, py::object, bool, bool, uint64_t, uint32_t>(), py::arg("write"),
           py::arg("counts"), py::arg("motor_output"), py::arg("imu_present"),
           py::arg("boot_us"), py::arg("boot_id"))
      .def("set_imu", &Core::set_imu, py::arg("answering"), py::arg("registers"))
      .def("advance_before", &Core::advance_before, py::arg("t_us"))
      .def("tick", &Core::tick)
      .def("push", &Core::push, py::arg("data"))
      .def_property_readonly("now_us", &Core::now_us)
      .def_property_readonly("session", [](const Core& c) { return c.fw().session_active(); })
      .def_property_readonly("next_telemetry_us",
                             [](const Core& c) { return c.fw().next_telemetry_us(); })
      .def_property_readonly("last_heartbeat_us",
                             [](const Core& c) { return c.fw().last_heartbeat_us(); })
      .def_property_readonly("host_lost_us", [](const Core& c) { return c.fw().host_lost_us(); })
      .def_property_readonly("heartbeats", [](const Core& c) { return c.fw().heartbeats(); })
      .def_property_readonly("sessions", [](const Core& c) { return c.fw().sessions(); })
      .def_property_readonly("heartbeat_ack",
                             [](const Core& c) {
                               uint8_t seq = 0;
                               const bool seen = c.fw().last_heartbeat_ack(seq);
                               return optional_seq(seen, seq);
                             })
      .def_property_readonly("last_telemetry_seq",
                             [](const Core& c) {
                               uint8_t seq = 0;
                               const bool sent = c.fw().last_telemetry_seq(seq);
                               return optional_seq(sent, seq);
                             })
      .def_property_readonly("motor_enable", &Core::line)
      .def_property_readonly("motors",
                             [](const Core& c) {
                               const auto& m = c.motors();
                               return py::make_tuple(m.left_, m.right_, m.braked_);
                             })
      .def_property_readonly("telemetry_rate_hz",
                             [](const Core& c) { return c.fw().config().telemetry_rate_hz; })
      .def_property_readonly("failsafe_ms",
                             [](const Core& c) { return c.fw().config().failsafe_ms; })
      .def_property_readonly("accel_fs", [](const Core& c) { return c.fw().imu().accel_fs(); })
      .def_property_readonly("gyro_fs", [](const Core& c) { return c.fw().imu().gyro_fs(); })
      .def_property_readonly("i2c_errors", [](const Core& c) { return c.fw().imu().errors(); })
      .def("telemetry_flags", [](const Core& c, uint32_t now) { return c.fw().telemetry_flags(now); },
           py::arg("t_us"));
}
