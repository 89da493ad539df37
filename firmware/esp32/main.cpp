// The ESP32-S3 board behind the HAL of firmware/core/hal.hpp: one small class per device, and
// app_main, which runs the portable core every millisecond under the task watchdog. Everything
// here only moves bytes and counts; all behaviour lives in the core and is tested on Linux.
#include <algorithm>
#include <array>
#include <atomic>
#include <cstring>

#include "board_config.hpp"
#include "driver/gpio.h"
#include "driver/i2c_master.h"
#include "driver/ledc.h"
#include "driver/pulse_cnt.h"
#include "driver/usb_serial_jtag.h"
#include "esp_err.h"
#include "esp_random.h"
#include "esp_task_wdt.h"
#include "esp_timer.h"
#include "firmware.hpp"
#include "freertos/FreeRTOS.h"
#include "freertos/task.h"
#include "hal.hpp"
#include "nvs.h"
#include "nvs_flash.h"
#include "sdkconfig.h"

namespace jackson::fw {
namespace {

static_assert(CONFIG_FREERTOS_HZ == 1000, "the loop and the I2C timeout assume 1 tick = 1 ms");
static_assert(board::kUsbTxQueueBytes >= protocol::kMaxFrame, "the TX queue must hold a frame");

constexpr uint32_t kTaskWatchdogMs = 2000;  // restarts the MCU if the loop below stops
constexpr char kNvsNamespace[] = "jackson";
constexpr size_t kUsbPacketBytes = 64;  // USB full-speed bulk endpoint
constexpr uint32_t kDutyFullScale = 10000;  // MotorOutput duty unit: 1e-4

constexpr gpio_num_t pin(int n) { return static_cast<gpio_num_t>(n); }

class EspClock final : public Clock {
 public:
  uint32_t micros() override { return static_cast<uint32_t>(esp_timer_get_time()); }
};

/// Two PCNT units in 4x quadrature. The hardware count resets to 0 at +-limit; the watch-point
/// ISR counts those events, and read() pairs them with the count consistently.
class PcntEncoders final : public Encoders {
 public:
  PcntEncoders()
      : left_(make_unit(board::kLeftEncoderA, board::kLeftEncoderB, left_events_)),
        right_(make_unit(board::kRightEncoderA, board::kRightEncoderB, right_events_)) {}

  int16_t limit() const override { return board::kPcntLimit; }

  void read(PcntSample& left, PcntSample& right) override {
    left = sample(left_, left_events_);
    right = sample(right_, right_events_);
  }

 private:
  // ISR context: +1 at the high limit, -1 at the low one.
  static bool on_reach(pcnt_unit_handle_t, const pcnt_watch_event_data_t* e, void* ctx) {
    auto* events = static_cast<std::atomic<int32_t>*>(ctx);
    if (e->watch_point_value == board::kPcntLimit) events->fetch_add(1, std::memory_order_relaxed);
    if (e->watch_point_value == -board::kPcntLimit) events->fetch_sub(1, std::memory_order_relaxed);
    return false;  // no task woken
  }

  // The events read before and after the count must agree, else the ISR ran in between. The
  // count is read in a critical section, so a limit reached before that read has its interrupt
  // served on leaving it, i.e. before the second load of the events.
  static PcntSample sample(pcnt_unit_handle_t unit, const std::atomic<int32_t>& events) {
    PcntSample s;
    int32_t before = 0;
    int count = 0;
    do {
      before = events.load();
      pcnt_unit_get_count(unit, &count);
      s.limit_events = events.load();
    } while (s.limit_events != before);
    s.count = static_cast<int16_t>(count);
    return s;
  }

  // Each channel counts both edges of one signal; the other signal's level gives the sign.
  static void add_channel(pcnt_unit_handle_t unit, int edge, int level,
                          pcnt_channel_edge_action_t on_rise, pcnt_channel_edge_action_t on_fall) {
    pcnt_chan_config_t cfg{};
    cfg.edge_gpio_num = edge;
    cfg.level_gpio_num = level;
    pcnt_channel_handle_t chan = nullptr;
    ESP_ERROR_CHECK(pcnt_new_channel(unit, &cfg, &chan));
    // Pull-ups for open-collector encoders: not every ESP-IDF 5.x PCNT driver enables them.
    ESP_ERROR_CHECK(gpio_pullup_en(pin(edge)));
    ESP_ERROR_CHECK(gpio_pullup_en(pin(level)));
    ESP_ERROR_CHECK(pcnt_channel_set_edge_action(chan, on_rise, on_fall));
    ESP_ERROR_CHECK(pcnt_channel_set_level_action(chan, PCNT_CHANNEL_LEVEL_ACTION_KEEP,
                                                  PCNT_CHANNEL_LEVEL_ACTION_INVERSE));
  }

  static pcnt_unit_handle_t make_unit(int a, int b, std::atomic<int32_t>& events) {
    pcnt_unit_config_t cfg{};
    cfg.low_limit = -board::kPcntLimit;
    cfg.high_limit = board::kPcntLimit;
    pcnt_unit_handle_t unit = nullptr;
    ESP_ERROR_CHECK(pcnt_new_unit(&cfg, &unit));
    pcnt_glitch_filter_config_t filter{};
    filter.max_glitch_ns = board::kGlitchFilterNs;
    ESP_ERROR_CHECK(pcnt_unit_set_glitch_filter(unit, &filter));
    add_channel(unit, a, b, PCNT_CHANNEL_EDGE_ACTION_DECREASE, PCNT_CHANNEL_EDGE_ACTION_INCREASE);
    add_channel(unit, b, a, PCNT_CHANNEL_EDGE_ACTION_INCREASE, PCNT_CHANNEL_EDGE_ACTION_DECREASE);
    ESP_ERROR_CHECK(pcnt_unit_add_watch_point(unit, board::kPcntLimit));
    ESP_ERROR_CHECK(pcnt_unit_add_watch_point(unit, -board::kPcntLimit));
    pcnt_event_callbacks_t callbacks{};
    callbacks.on_reach = &PcntEncoders::on_reach;
    ESP_ERROR_CHECK(pcnt_unit_register_event_callbacks(unit, &callbacks, &events));
    ESP_ERROR_CHECK(pcnt_unit_enable(unit));
    ESP_ERROR_CHECK(pcnt_unit_clear_count(unit));
    ESP_ERROR_CHECK(pcnt_unit_start(unit));
    return unit;
  }

  // Declared before the handles: make_unit() hands their addresses to the ISR.
  std::atomic<int32_t> left_events_{0};
  std::atomic<int32_t> right_events_{0};
  pcnt_unit_handle_t left_;
  pcnt_unit_handle_t right_;
};

/// The MPU-6050 on an i2c_master bus; every transaction is bounded by kI2cTimeoutMs.
class EspI2c final : public I2cBus {
 public:
  EspI2c() {
    i2c_master_bus_config_t bus{};
    bus.i2c_port = -1;  // any free controller
    bus.sda_io_num = pin(board::kI2cSda);
    bus.scl_io_num = pin(board::kI2cScl);
    bus.clk_source = I2C_CLK_SRC_DEFAULT;
    bus.glitch_ignore_cnt = 7;
    bus.flags.enable_internal_pullup = 1;  // weak; the GY-521 carries its own pull-ups
    ESP_ERROR_CHECK(i2c_new_master_bus(&bus, &bus_));
    i2c_device_config_t dev{};
    dev.dev_addr_length = I2C_ADDR_BIT_LEN_7;
    dev.device_address = mpu6050::kAddress;
    dev.scl_speed_hz = board::kI2cHz;
    ESP_ERROR_CHECK(i2c_master_bus_add_device(bus_, &dev, &imu_));
  }

  bool write_reg(uint8_t addr, uint8_t reg, uint8_t value) override {
    const uint8_t bytes[2] = {reg, value};
    return addr == mpu6050::kAddress &&
           ok(i2c_master_transmit(imu_, bytes, sizeof bytes, board::kI2cTimeoutMs));
  }

  bool read_regs(uint8_t addr, uint8_t reg, uint8_t* out, size_t n) override {
    return addr == mpu6050::kAddress &&
           ok(i2c_master_transmit_receive(imu_, &reg, 1, out, n, board::kI2cTimeoutMs));
  }

 private:
  // A timeout may leave the bus held by a half-finished transfer: reset it for the next retry.
  bool ok(esp_err_t err) {
    if (err == ESP_ERR_TIMEOUT) i2c_master_bus_reset(bus_);
    return err == ESP_OK;
  }

  i2c_master_bus_handle_t bus_ = nullptr;
  i2c_master_dev_handle_t imu_ = nullptr;
};

/// The native USB CDC port (usb_serial_jtag driver), never blocking. The driver's write with
/// ticks_to_wait 0 is not all-or-nothing in every IDF version: with the FIFO idle it writes what
/// fits there, then queues the rest, and if its ring lacks room returns 0 although a prefix went
/// out. So a frame is first accepted whole into this class's queue, or refused (the core counts
/// the drop); drain() then hands the driver one USB packet at a time and keeps what it did not
/// take for the next call (every tick, through read()): frames leave whole and in order. In the
/// unlikely case "FIFO idle, ring full", the host's decoder drops the repeated bytes by CRC.
class UsbSerial final : public SerialPort {
 public:
  UsbSerial() {
    usb_serial_jtag_driver_config_t cfg{};
    cfg.tx_buffer_size = board::kUsbTxBufferBytes;
    cfg.rx_buffer_size = board::kUsbRxBufferBytes;
    ESP_ERROR_CHECK(usb_serial_jtag_driver_install(&cfg));
  }

  bool write_all_or_nothing(const uint8_t* data, size_t n) override {
    drain();
    if (n > queue_.size() - queued_) return false;
    std::memcpy(queue_.data() + queued_, data, n);
    queued_ += n;
    drain();
    return true;
  }

  size_t read(uint8_t* out, size_t cap) override {
    drain();
    const int n = usb_serial_jtag_read_bytes(out, static_cast<uint32_t>(cap), 0);
    return n > 0 ? static_cast<size_t>(n) : 0;
  }

 private:
  void drain() {
    size_t sent = 0;
    while (sent < queued_) {
      const size_t chunk = std::min(queued_ - sent, kUsbPacketBytes);
      const int n = usb_serial_jtag_write_bytes(queue_.data() + sent, chunk, 0);
      if (n <= 0 || static_cast<size_t>(n) > chunk) break;
      sent += static_cast<size_t>(n);
    }
    if (sent == 0) return;
    std::memmove(queue_.data(), queue_.data() + sent, queued_ - sent);
    queued_ -= sent;
  }

  std::array<uint8_t, board::kUsbTxQueueBytes> queue_{};
  size_t queued_ = 0;
};

/// Blobs in the NVS namespace "jackson".
class NvsStorage final : public Storage {
 public:
  NvsStorage() { open_ = nvs_open(kNvsNamespace, NVS_READWRITE, &handle_) == ESP_OK; }

  bool load(const char* key, void* out, size_t n) override {
    size_t stored = 0;
    if (!open_ || nvs_get_blob(handle_, key, nullptr, &stored) != ESP_OK || stored != n) {
      return false;
    }
    return nvs_get_blob(handle_, key, out, &stored) == ESP_OK;
  }

  bool save(const char* key, const void* data, size_t n) override {
    return open_ && nvs_set_blob(handle_, key, data, n) == ESP_OK && nvs_commit(handle_) == ESP_OK;
  }

 private:
  nvs_handle_t handle_ = 0;
  bool open_ = false;
};

/// The interlock line (board::kMotorEnablePin, docs/firmware.md "Motor interlock"): the output
/// latch is set to the disabled level before the pin becomes an output, so it never glitches to
/// enabled; the external pull resistor holds that level before this runs and after any reset.
class GpioMotorEnable final : public MotorEnable {
 public:
  static constexpr int kEnabled = board::kMotorEnableActiveLevel;
  static constexpr int kDisabled = 1 - board::kMotorEnableActiveLevel;

  GpioMotorEnable() {
    ESP_ERROR_CHECK(gpio_set_level(pin(), kDisabled));
    gpio_config_t out{};
    out.pin_bit_mask = uint64_t{1} << static_cast<unsigned>(pin());
    out.mode = GPIO_MODE_OUTPUT;
    out.pull_up_en = GPIO_PULLUP_DISABLE;  // the external 10 kOhm decides while the pin floats
    out.pull_down_en = GPIO_PULLDOWN_DISABLE;
    out.intr_type = GPIO_INTR_DISABLE;
    ESP_ERROR_CHECK(gpio_config(&out));
    ESP_ERROR_CHECK(gpio_set_level(pin(), kDisabled));
  }
  void set(bool enabled) override { gpio_set_level(pin(), enabled ? kEnabled : kDisabled); }

 private:
  static constexpr gpio_num_t pin() {
    return static_cast<gpio_num_t>(board::kMotorEnablePin >= 0 ? board::kMotorEnablePin : 0);
  }
};

/// TB6612FNG: LEDC PWM, direction on IN1/IN2, STBY held high once braked. Datasheet truth table:
/// IN1 H, IN2 L, PWM H: forward; IN1 L, IN2 H, PWM H: reverse; IN1 = IN2 = H, or PWM L: short
/// brake; STBY L: outputs off.
class Tb6612Motors final : public MotorOutput {
 public:
  Tb6612Motors() {
    gpio_config_t out{};
    out.pin_bit_mask = bit(board::kMotorAIn1) | bit(board::kMotorAIn2) |
                       bit(board::kMotorBIn1) | bit(board::kMotorBIn2) | bit(board::kMotorStby);
    out.mode = GPIO_MODE_OUTPUT;
    ESP_ERROR_CHECK(gpio_config(&out));
    ESP_ERROR_CHECK(gpio_set_level(pin(board::kMotorStby), 0));
    ledc_timer_config_t timer{};
    timer.speed_mode = LEDC_LOW_SPEED_MODE;
    timer.duty_resolution = static_cast<ledc_timer_bit_t>(board::kPwmResolutionBits);
    timer.timer_num = LEDC_TIMER_0;
    timer.freq_hz = board::kPwmHz;
    timer.clk_cfg = LEDC_AUTO_CLK;
    ESP_ERROR_CHECK(ledc_timer_config(&timer));
    for (const Bridge& b : {kLeft, kRight}) {
      ledc_channel_config_t ch{};
      ch.gpio_num = b.pwm;
      ch.speed_mode = LEDC_LOW_SPEED_MODE;
      ch.channel = b.channel;
      ch.timer_sel = LEDC_TIMER_0;
      ch.duty = 0;
      ESP_ERROR_CHECK(ledc_channel_config(&ch));
    }
    brake();
    ESP_ERROR_CHECK(gpio_set_level(pin(board::kMotorStby), 1));
  }

  void drive(int16_t left, int16_t right) override {
    set(kLeft, left);
    set(kRight, right);
  }

  void brake() override {
    for (const Bridge& b : {kLeft, kRight}) {
      gpio_set_level(pin(b.in1), 1);
      gpio_set_level(pin(b.in2), 1);
      set_pwm(b, kPwmMax);
    }
  }

 private:
  struct Bridge {
    int pwm, in1, in2;
    ledc_channel_t channel;
  };
  static constexpr Bridge kLeft{board::kMotorPwmA, board::kMotorAIn1, board::kMotorAIn2,
                                LEDC_CHANNEL_0};
  static constexpr Bridge kRight{board::kMotorPwmB, board::kMotorBIn1, board::kMotorBIn2,
                                 LEDC_CHANNEL_1};
  static constexpr uint32_t kPwmMax = 1u << board::kPwmResolutionBits;  // 2^bits: always high

  static constexpr uint64_t bit(int n) { return uint64_t{1} << n; }

  static void set(const Bridge& b, int16_t duty) {
    const bool forward = duty >= 0;
    gpio_set_level(pin(b.in1), forward ? 1 : 0);
    gpio_set_level(pin(b.in2), forward ? 0 : 1);
    const auto magnitude = static_cast<uint32_t>(forward ? duty : -int32_t{duty});
    set_pwm(b, (magnitude * kPwmMax + kDutyFullScale / 2) / kDutyFullScale);
  }

  static void set_pwm(const Bridge& b, uint32_t duty) {
    ledc_set_duty(LEDC_LOW_SPEED_MODE, b.channel, std::min(duty, kPwmMax));
    ledc_update_duty(LEDC_LOW_SPEED_MODE, b.channel);
  }
};

void init_nvs() {
  esp_err_t err = nvs_flash_init();
  if (err == ESP_ERR_NVS_NO_FREE_PAGES || err == ESP_ERR_NVS_NEW_VERSION_FOUND) {
    ESP_ERROR_CHECK(nvs_flash_erase());  // unreadable partition: start empty
    err = nvs_flash_init();
  }
  ESP_ERROR_CHECK(err);
}

// Panics (and so restarts the MCU) when the loop task stops resetting it for kTaskWatchdogMs.
void watch_this_task() {
  esp_task_wdt_config_t cfg{};
  cfg.timeout_ms = kTaskWatchdogMs;
#ifdef CONFIG_FREERTOS_NUMBER_OF_CORES  // ESP-IDF 5.3 and later
  cfg.idle_core_mask = (1u << CONFIG_FREERTOS_NUMBER_OF_CORES) - 1u;
#else
  cfg.idle_core_mask = (1u << portNUM_PROCESSORS) - 1u;
#endif
  cfg.trigger_panic = true;
  if (esp_task_wdt_reconfigure(&cfg) == ESP_ERR_INVALID_STATE) {
    ESP_ERROR_CHECK(esp_task_wdt_init(&cfg));
  }
  ESP_ERROR_CHECK(esp_task_wdt_add(nullptr));
}

}  // namespace
}  // namespace jackson::fw

extern "C" void app_main(void) {
  using namespace jackson::fw;
  // the interlock line before anything else: the motors stay disabled (OE high / STBY low)
  // until the firmware core asserts it on the host's heartbeats
  MotorEnable* enable = nullptr;
  if constexpr (board::kMotorEnablePin >= 0) {
    static GpioMotorEnable line;  // held at its disabled level from here on
    enable = &line;
  }
  init_nvs();
  // Static storage: everything is built once here, nothing is allocated afterwards.
  static EspClock clock;
  static PcntEncoders encoders;
  static EspI2c i2c;
  static UsbSerial serial;
  static NvsStorage storage;
  MotorOutput* motors = nullptr;
  if constexpr (board::kMcuDrivesMotors) {
    static Tb6612Motors tb6612;
    motors = &tb6612;
  }
  // a new random boot_id each boot lets the host tell a reset from a reconnect
  static Hal hal{clock, encoders, i2c, serial, storage, motors, esp_random() | 1u, enable};
  static Firmware firmware(hal);
  firmware.begin();
  watch_this_task();
  for (;;) {
    firmware.tick();
    esp_task_wdt_reset();
    vTaskDelay(1);  // 1 ms: lets the idle task run
  }
}
