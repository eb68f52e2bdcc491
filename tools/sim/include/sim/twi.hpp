// The ATmega2560's TWI (I2C) as the chip has it (datasheet ch. 24), in master mode, in place of
// simavr 1.6's model, which reads TWINT as set right after the write that clears it, answers
// SLA+W with 0x28 and takes the same time whatever TWBR says (fixed upstream in 1.7/1.8).
// The harness takes over TWCR, TWDR and TWSR through simavr's io[] table:
//   - TWINT is write-one-to-clear and set by hardware only when an operation ends; an operation
//     (START, SLA+R/W, a data byte, STOP) starts when TWINT is clear; TWSTO clears itself when
//     the STOP is done; a TWDR write while TWINT is clear sets TWWC and is ignored; TWSR's
//     status bits are read-only, TWPS is not.
//   - time: one SCL bit is 16 + 2 * TWBR * 4^TWPS CPU cycles; a byte with its (N)ACK 9 bits;
//     START, repeated START and STOP one bit each (a model choice: the datasheet gives bus
//     timing, not the TWINT latency of a condition).
//   - the TWI interrupt (vector TWI_vect) is level-triggered like the chip's: pending while
//     TWINT and TWIE are both set, again after a RETI that left them set.
//   - slaves speak simavr's TWI message protocol (avr_twi_irq_msg: START with the SLA byte,
//     WRITE, READ with ACK when the master acknowledges, STOP) on irq(): the master raises
//     [TWI_IRQ_OUTPUT]; a slave answers inside that call on [TWI_IRQ_INPUT] (ACK, or READ with
//     its byte), as simavr's examples/parts/i2c_eeprom.c does. A slave that does not answer
//     is a NACK; a byte nobody drives reads 0xFF.
//   - the lines: with pull-ups on the bus (setPullUps, a breakout board's resistors) PIND reads
//     SDA/SCL high; a slave can hold SDA low (holdSdaLow, a fault): a START then waits for a
//     free bus, a master that sends a 1 loses arbitration (0x38), a STOP cannot happen; the
//     slave lets go after N SCL clocks made with the pins as GPIO (the usual bus recovery).
// Slave mode (TWAR) is not modelled. Pins and bus rates: hal/board.hpp.
#pragma once
#include <cstdint>
#include <vector>

struct avr_t;
struct avr_irq_t;
struct avr_int_vector_t;

namespace sim {

// One thing the TWI did, with the cycle it happened (for tests and docs).
struct TwiEvent {
  enum class What : uint8_t { kOpStart, kStatus };
  uint64_t cycle;
  What what;
  uint8_t value;  // kOpStart: the operation (TwiOp), kStatus: the new TWSR status
};

enum class TwiOp : uint8_t { kStart, kRepeatedStart, kAddress, kWrite, kRead, kStop };

class Twi {
 public:
  // Takes over the TWI registers of `avr` (an atmega2560 made by avr_make_mcu_by_name and
  // avr_init). Throws std::runtime_error if the core has no TWI.
  explicit Twi(avr_t* avr);
  ~Twi();
  Twi(const Twi&) = delete;
  Twi& operator=(const Twi&) = delete;

  // TWI_IRQ_COUNT IRQs in simavr's order (TWI_IRQ_INPUT, TWI_IRQ_OUTPUT, TWI_IRQ_STATUS):
  // connect a slave part's IRQs to them.
  avr_irq_t* irq() { return irq_; }

  // A chip reset ended every transfer (Board calls it after each reset).
  void afterReset();

  // Pull-up resistors on SDA and SCL (a device on the bus): PIND reads the lines' levels, and
  // simavr's every-cycle polling of low-level INT0/INT1 is turned off for the two pins.
  void setPullUps(bool on);
  // A slave holds SDA low from now on; it lets go after `release_after_scl_clocks` rising SCL
  // edges made by the firmware with PD0 as GPIO (0: never, until releaseSda()).
  void holdSdaLow(int release_after_scl_clocks = 0);
  void releaseSda();
  bool sdaHeldLow() const { return sda_low_; }

  // CPU cycles of one SCL bit at the present TWBR / TWPS.
  uint64_t bitCycles() const;
  uint8_t status() const;

  // Every operation start and status change from now on (off by default: a flight loop makes
  // thousands a second).
  void setTracing(bool on) { tracing_ = on; }
  const std::vector<TwiEvent>& trace() const { return trace_; }
  void clearTrace() { trace_.clear(); }

 private:
  static void onControlWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  static void onDataWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  static uint8_t onDataRead(avr_t* avr, uint16_t addr, void* param);
  static void onStatusWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  static void onSlaveAnswer(avr_irq_t* irq, uint32_t value, void* param);
  static void onVectorRunning(avr_irq_t* irq, uint32_t value, void* param);
  static void onSclPin(avr_irq_t* irq, uint32_t value, void* param);
  static uint64_t onOpDone(avr_t* avr, uint64_t when, void* param);
  static uint64_t onAfterResetCycle(avr_t* avr, uint64_t when, void* param);

  void writeControl(uint8_t v);
  void switchOff();
  void startNext(bool twint_cleared);
  void begin(TwiOp op, uint64_t after_cycles, uint8_t status);
  void beginStart();
  void beginByte();
  void beginStop();
  void finish(uint64_t when);
  void busFreed();
  void raiseLevelInterrupt();
  void toSlaves(uint8_t msg, uint8_t addr, uint8_t data);
  void applyLines();
  void record(TwiEvent::What what, uint8_t value);
  uint8_t& reg(uint16_t addr);

  avr_t* avr_;
  avr_int_vector_t* vector_ = nullptr;  // the core's TWI vector (TWIE enables, TWINT raises)
  avr_irq_t* irq_ = nullptr;
  avr_irq_t* scl_pin_ = nullptr;
  avr_irq_t* sda_pin_ = nullptr;

  bool master_ = false;         // this TWI holds the bus (after START, until STOP / lost)
  bool busy_ = false;           // an operation runs (its end is a cycle timer)
  bool start_waiting_ = false;  // START asked while another device held the bus
  bool bus_held_ = false;       // the bus is busy without us (SDA held low, no STOP seen)
  bool reading_ = false;        // the last SLA had R/W = 1
  bool slave_acked_ = false;    // the last SLA was acknowledged
  bool slave_released_ = false; // master receiver sent NACK: the slave no longer drives SDA
  bool answer_ack_ = false;     // what the slave answered to the present byte
  bool answer_read_ = false;
  uint8_t answer_data_ = 0xFF;
  // The operation in flight: what it sets when it ends.
  TwiOp op_ = TwiOp::kStop;
  uint8_t op_status_ = 0xF8;
  uint8_t op_data_ = 0;
  bool op_sets_data_ = false;
  bool op_sets_twint_ = true;
  bool op_lost_ = false;        // arbitration lost in this operation

  bool pull_ups_ = false;
  bool sda_low_ = false;
  int release_clocks_left_ = 0;

  bool tracing_ = false;
  std::vector<TwiEvent> trace_;
};

}  // namespace sim
