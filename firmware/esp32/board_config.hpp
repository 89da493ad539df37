// The ESP32-S3 board in one place: pins, peripheral settings and build options. Rewire the robot
// here, not in main.cpp; docs/firmware.md has the matching wiring table.
#pragma once

#include <cstddef>
#include <cstdint>

namespace jackson::fw::board {

// Pins of an ESP32-S3-DevKitC-1 with an N16R8 module. Left alone: strapping pins 0, 3, 45, 46;
// native USB 19/20; flash 26-32; octal PSRAM 33-37; RGB LED 38/48; UART0 console 43/44.

/// Quadrature encoders (3.3 V logic). Channel A leading B counts up; if a wheel counts backwards
/// when driven forward, set its direction flag with SET_CONFIG instead of rewiring.
constexpr int kLeftEncoderA = 4;
constexpr int kLeftEncoderB = 5;
constexpr int kRightEncoderA = 6;
constexpr int kRightEncoderB = 7;

/// MPU-6050 (GY-521 breakout, AD0 low: address 0x68).
constexpr int kI2cSda = 8;
constexpr int kI2cScl = 9;
constexpr uint32_t kI2cHz = 400'000;
constexpr int kI2cTimeoutMs = 2;  ///< per transaction; a 14-byte burst read takes about 0.5 ms

/// Whether this MCU drives a TB6612FNG itself. The paper's robot drives its motors from the
/// Jetson through a PCA9685, so the default leaves the pins below untouched.
constexpr bool kMcuDrivesMotors = false;
/// TB6612FNG: channel A is the left motor, channel B the right one.
constexpr int kMotorPwmA = 10;
constexpr int kMotorAIn1 = 11;
constexpr int kMotorAIn2 = 12;
constexpr int kMotorPwmB = 13;
constexpr int kMotorBIn1 = 14;
constexpr int kMotorBIn2 = 15;
constexpr int kMotorStby = 16;

/// Motor interlock (docs/firmware.md, "Motor interlock"). This GPIO drives the PCA9685's
/// active-low OE pin (output enable), with a 10 kOhm pull-up from OE to the PCA9685's VCC, so OE
/// is high (outputs disabled) whenever the ESP32 is in reset (its pins float as inputs),
/// unpowered, unplugged, or simply not asserting the line. The firmware drives it low (enabled)
/// only during a session while HEARTBEATs arrive within failsafe_ms, and releases it at boot, on
/// HOST_LOST and on a SHUTDOWN heartbeat. With OE high the PCA9685 outputs follow MODE2 OUTNE:
/// the host writes OUTDRV | OUTNE=01, so all go high and both TB6612 bridges short-brake (IN1 =
/// IN2 = PWM = H); a PCA9685 back at its power-on MODE2 (OUTNE=00) drives them low: coast.
/// Boards without OE access: wire this GPIO to the TB6612's STBY with a 10 kOhm pull-down to GND
/// instead (STBY low = standby, outputs Hi-Z) and set kMotorEnableActiveLevel = 1.
/// GPIO17: a plain I/O of the S3 (not strapping, USB, flash, PSRAM, LED or console, see above) and
/// none of the pins used here; it floats at reset, so the pull resistor decides. -1: not wired.
constexpr int kMotorEnablePin = 17;
/// GPIO level that enables the motors: 0 for PCA9685 OE (active low), 1 for TB6612 STBY.
constexpr int kMotorEnableActiveLevel = 0;
static_assert(kMotorEnablePin < 0 ||
                  (kMotorEnablePin != kLeftEncoderA && kMotorEnablePin != kLeftEncoderB &&
                   kMotorEnablePin != kRightEncoderA && kMotorEnablePin != kRightEncoderB &&
                   kMotorEnablePin != kI2cSda && kMotorEnablePin != kI2cScl &&
                   (!kMcuDrivesMotors ||
                    (kMotorEnablePin < kMotorPwmA || kMotorEnablePin > kMotorStby))),
              "the interlock pin must not share a pin with the encoders, the I2C bus or the "
              "MCU's TB6612 outputs");
static_assert(kMotorEnableActiveLevel == 0 || kMotorEnableActiveLevel == 1,
              "kMotorEnableActiveLevel is a GPIO level: 0 (OE) or 1 (STBY)");

/// PCNT: the 16-bit counter resets to 0 on reaching +-limit; the HAL counts those events.
constexpr int16_t kPcntLimit = 30000;
/// Pulses shorter than this are ignored (the filter holds at most 1023 APB cycles, ~12.7 us).
constexpr uint32_t kGlitchFilterNs = 1000;

/// LEDC PWM for the TB6612 (which accepts up to 100 kHz). 20 kHz is above hearing; one period is
/// 80 MHz / 20 kHz = 4000 APB clocks, so 11 bits at most; 10 bits also fit a 40 MHz source.
constexpr uint32_t kPwmHz = 20'000;
constexpr int kPwmResolutionBits = 10;

/// USB Serial/JTAG (the S3's native USB CDC port). The HAL's own queue takes frames whole and
/// feeds the driver's ring buffer; together they hold about 3 s of 20 Hz telemetry.
constexpr size_t kUsbTxBufferBytes = 2048;  ///< driver ring buffer
constexpr size_t kUsbRxBufferBytes = 512;   ///< driver ring buffer, must exceed 64
constexpr size_t kUsbTxQueueBytes = 512;    ///< HAL queue, at least one maximal frame (130 B)

static_assert(kPcntLimit > 0, "the PCNT limits are +-kPcntLimit");
static_assert(kGlitchFilterNs <= 12'000, "the PCNT glitch filter holds at most 1023 APB cycles");
static_assert((uint64_t{1} << kPwmResolutionBits) * kPwmHz <= 80'000'000,
              "LEDC resolution too fine for this frequency");
static_assert(kUsbRxBufferBytes > 64, "the USB Serial/JTAG driver needs more than 64 RX bytes");

}  // namespace jackson::fw::board
