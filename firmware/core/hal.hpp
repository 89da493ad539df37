// The hardware abstraction the firmware core calls. The ESP32-S3 implements it in firmware/esp32,
// Linux in firmware/posix (a pty plus a sensor feed from the digital twin), the unit tests with
// fakes. The core never calls the board any other way, and the HAL never calls into the core.
#pragma once

#include <cstddef>
#include <cstdint>

namespace jackson::fw {

/// Microsecond clock. Wraps at 2^32 like the protocol's t_us.
class Clock {
 public:
  virtual ~Clock() = default;
  virtual uint32_t micros() = 0;
};

/// One wheel's pulse counter as the ESP32 PCNT unit presents it: a 16-bit hardware count that
/// resets to 0 whenever it reaches +-limit, and the number of such events seen by the ISR.
struct PcntSample {
  int16_t count = 0;           ///< current hardware count, in (-limit, +limit)
  int32_t limit_events = 0;    ///< (# of +limit events) - (# of -limit events), since boot
};

/// Both wheels' counters (4x quadrature, glitch filter configured by the HAL).
class Encoders {
 public:
  virtual ~Encoders() = default;
  /// The PCNT limit used for both units (the core multiplies limit_events by it).
  virtual int16_t limit() const = 0;
  /// A consistent (count, limit_events) pair per wheel; never blocks.
  virtual void read(PcntSample& left, PcntSample& right) = 0;
};

/// Register access on the IMU's I2C bus (400 kHz). Each call is one bounded transaction
/// (the ESP32 HAL uses a few-millisecond timeout): it returns false on NACK or timeout.
class I2cBus {
 public:
  virtual ~I2cBus() = default;
  virtual bool write_reg(uint8_t addr, uint8_t reg, uint8_t value) = 0;
  virtual bool read_regs(uint8_t addr, uint8_t reg, uint8_t* out, size_t n) = 0;
};

/// The link to the host (USB CDC on the robot, a pty on Linux). Never blocks.
class SerialPort {
 public:
  virtual ~SerialPort() = default;
  /// Writes all n bytes or none (returns false when the TX buffer lacks room: frame dropped).
  virtual bool write_all_or_nothing(const uint8_t* data, size_t n) = 0;
  /// Copies up to cap received bytes into out; returns how many (0 when none are waiting).
  virtual size_t read(uint8_t* out, size_t cap) = 0;
};

/// Non-volatile storage of small blobs (NVS on the ESP32, a file on Linux).
class Storage {
 public:
  virtual ~Storage() = default;
  /// Loads blob `key` into out; false when absent or of another size.
  virtual bool load(const char* key, void* out, size_t n) = 0;
  virtual bool save(const char* key, const void* data, size_t n) = 0;
};

/// TB6612FNG outputs driven by the MCU (optional: a robot may drive its motors from the host).
class MotorOutput {
 public:
  virtual ~MotorOutput() = default;
  /// Signed duty per wheel in 1e-4 units, already clamped to +-10000 and direction-corrected.
  virtual void drive(int16_t left, int16_t right) = 0;
  /// Short brake on both motors (IN1 = IN2 = high).
  virtual void brake() = 0;
};

/// The motor interlock line (docs/firmware.md, "Motor interlock"): a GPIO wired to the PCA9685's
/// active-low OE pin (pulled up: outputs disabled) or the TB6612's STBY (pulled down). The core
/// asserts it only while the host's heartbeats are live, so a dead or hung host, an MCU reset
/// and an unplugged board all stop the motors whichever chip drives them.
class MotorEnable {
 public:
  virtual ~MotorEnable() = default;
  /// true: outputs enabled (OE low / STBY high); false: disabled (the pull resistor's state).
  virtual void set(bool enabled) = 0;
};

/// Everything the core needs from a board. `motors` may be null (no motor output).
/// `boot_id` is a random non-zero number drawn at every boot (the ESP32's hardware RNG); INFO
/// reports it, so the host tells an MCU reset from a reconnect.
struct Hal {
  Clock& clock;
  Encoders& encoders;
  I2cBus& i2c;
  SerialPort& serial;
  Storage& storage;
  MotorOutput* motors;
  uint32_t boot_id = 1;
  MotorEnable* motor_enable = nullptr;  ///< the interlock line; null when not wired
};

}  // namespace jackson::fw
