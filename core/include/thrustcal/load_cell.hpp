// Load cell (Vetek 1 kg single point + INA125P + 3rd-order RC low-pass into A0, 10-bit ADC).
//
// Thesis eq. (sec. 6.1):  line_g = 0.75 * counts - 156   (valueEkv).
// A weight pressing *down* on the plate lowers the reading; thrust pushing *up* raises it.
// Phase 1 (weighing, before calibration):   weight_g = -line_g - plate_g
// Calibration with a known weight (thesis CALIBRATION_VALUE): shifts the line so that the
//   weight now on the plate (motor + propeller, without the plate) reads as the known weight.
// Span calibration (beyond the thesis): scales the slope from a known weight change.
// Phase 2 ("zerolize", tare): force_g = line_g - line_g(at tare), thrust positive.
#pragma once
#include <stdint.h>

namespace tc {

struct LoadCellConfig {
  int32_t slope_ug_per_count = 750000;  // thesis 0.75 g per ADC count (micrograms per count)
  int32_t offset_mg = -156000;          // thesis -156 g
  int16_t plate_g = 60;                 // plate carrying the motor (thesis 60 g)
  int16_t overload_g = 950;             // |load| above this aborts a sweep (cell is 1 kg)
  uint16_t adc_max_counts = 1023;
  uint16_t rail_margin_counts = 2;      // readings this close to 0 or adc_max are implausible
};

enum class LoadCellStatus : uint8_t {
  kOk = 0,
  kOverload,     // |force| or |weight| above overload_g
  kImplausible,  // ADC at a rail: amplifier saturated, wire off, or no supply
};

class LoadCell {
 public:
  explicit LoadCell(const LoadCellConfig& config = LoadCellConfig()) : config_(config) {}

  // Thesis line including the calibration shift, in milligrams.
  int32_t lineMilligrams(uint16_t counts) const;
  // Phase 1: grams resting on the plate, plate excluded (rounded to nearest).
  int16_t weightGrams(uint16_t counts) const;
  // Thesis calibration: afterwards weightGrams(counts) == known_weight_g. Returns false (and
  // changes nothing) if known_weight_g is not in 1..overload_g.
  bool calibrateWeight(uint16_t counts, int16_t known_weight_g);
  // Span: `counts_loaded` was read with `known_weight_g` more on the plate than `counts_empty`.
  // Scales the slope, pivoting the line at counts_empty (the empty plate keeps its reading),
  // and drops the tare (isTared() false: tare again). Returns false (changes nothing) if
  // known_weight_g is not in 1..overload_g, the reading fell by under 10 counts (or rose),
  // or the resulting slope is outside 0.25..3 g/count.
  bool calibrateSpan(uint16_t counts_empty, uint16_t counts_loaded, int16_t known_weight_g);
  // Zerolize: afterwards forceMilligrams(counts) == 0.
  void tare(uint16_t counts);
  // The same with a reading in 1/16 count (MedianFilter::centralMeanQ4): tareQ4(c * 16) is
  // tare(c).
  void tareQ4(uint16_t counts_q4);
  bool isTared() const { return tared_; }
  // Phase 2: upward force since tare, thrust positive.
  int32_t forceMilligrams(uint16_t counts) const;
  int16_t forceGrams(uint16_t counts) const;  // rounded to nearest
  // The force at a reading in 1/16 count: forceMilligramsQ4(c * 16) == forceMilligrams(c).
  int32_t forceMilligramsQ4(uint16_t counts_q4) const;
  // Overload / rail check for one (median) reading: kImplausible within rail_margin_counts of
  // 0 or adc_max; kOverload when |weightGrams| or, once tared, |forceGrams| exceeds overload_g.
  LoadCellStatus check(uint16_t counts) const;

  const LoadCellConfig& config() const { return config_; }
  void setPlateGrams(int16_t plate_g) { config_.plate_g = plate_g; }
  int32_t calibrationMilligrams() const { return calibration_mg_; }

 private:
  LoadCellConfig config_;
  int32_t calibration_mg_ = 0;  // thesis CALIBRATION_VALUE
  int32_t zero_mg_ = 0;         // thesis ZEROLIZE_VALUE
  bool tared_ = false;
};

}  // namespace tc
