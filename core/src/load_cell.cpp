// Load cell conversion, integer only (milligrams in int32): 0.75 g/count * 1023 counts fits
// easily, and the slope product is split so that even 3 g/count cannot overflow int32.
#include "thrustcal/load_cell.hpp"

namespace tc {

namespace {

constexpr int32_t kMinSlopeUgPerCount = 250000;   // 0.25 g/count
constexpr int32_t kMaxSlopeUgPerCount = 3000000;  // 3 g/count
constexpr int32_t kMinSpanCounts = 10;

// Nearest integer of num / den for den > 0, halves away from zero.
int32_t divRound(int32_t num, int32_t den) {
  const int32_t q = num / den;
  const int32_t r = num % den;  // same sign as num
  if (r >= 0) return (2 * r >= den) ? q + 1 : q;
  return (-2 * r >= den) ? q - 1 : q;
}

// slope [ug/count] * counts in milligrams, rounded; no int32 overflow for |slope| <= 2^31/1024.
int32_t slopeMilligrams(int32_t slope_ug_per_count, uint16_t counts) {
  const int32_t whole_mg = slope_ug_per_count / 1000;  // |.| <= 2.1e6 / 1000 per count
  const int32_t frac_ug = slope_ug_per_count % 1000;
  return whole_mg * counts + divRound(frac_ug * counts, 1000);
}

// The same for a reading in 1/16 count: whole counts as slopeMilligrams, the fraction's
// slope * frac / 16 rounded (|slope * 15| < 2^31 for |slope| <= 3 g/count).
int32_t slopeMilligramsQ4(int32_t slope_ug_per_count, uint16_t counts_q4) {
  const uint16_t frac = counts_q4 & 15u;
  const int32_t whole = slopeMilligrams(slope_ug_per_count, static_cast<uint16_t>(counts_q4 >> 4));
  if (frac == 0) return whole;
  return whole + divRound(slope_ug_per_count * static_cast<int32_t>(frac), 16000);
}

int16_t saturateGrams(int32_t mg) {
  const int32_t g = divRound(mg, 1000);
  if (g > 32767) return 32767;
  if (g < -32768) return -32768;
  return static_cast<int16_t>(g);
}

int32_t absolute(int32_t v) { return v < 0 ? -v : v; }

}  // namespace

int32_t LoadCell::lineMilligrams(uint16_t counts) const {
  return slopeMilligrams(config_.slope_ug_per_count, counts) + config_.offset_mg - calibration_mg_;
}

int16_t LoadCell::weightGrams(uint16_t counts) const {
  return saturateGrams(-lineMilligrams(counts) - static_cast<int32_t>(config_.plate_g) * 1000);
}

bool LoadCell::calibrateWeight(uint16_t counts, int16_t known_weight_g) {
  if (known_weight_g < 1 || known_weight_g > config_.overload_g) return false;
  // Thesis: CALIBRATION_VALUE = CALIB_WEIGHT + START_WEIGHT + valueEkv + CALIBRATION_VALUE,
  // i.e. the line without any calibration shift, plus known weight and plate.
  const int32_t uncalibrated_mg = lineMilligrams(counts) + calibration_mg_;
  calibration_mg_ = static_cast<int32_t>(known_weight_g) * 1000 +
                    static_cast<int32_t>(config_.plate_g) * 1000 + uncalibrated_mg;
  return true;
}

bool LoadCell::calibrateSpan(uint16_t counts_empty, uint16_t counts_loaded,
                             int16_t known_weight_g) {
  if (known_weight_g < 1 || known_weight_g > config_.overload_g) return false;
  // Weight pressing down lowers the reading: loaded < empty for a proper cell.
  const int32_t drop_counts = static_cast<int32_t>(counts_empty) - counts_loaded;
  if (drop_counts < kMinSpanCounts) return false;  // too small, or the wrong direction
  const int32_t slope = divRound(static_cast<int32_t>(known_weight_g) * 1000000L, drop_counts);
  if (slope < kMinSlopeUgPerCount || slope > kMaxSlopeUgPerCount) return false;
  // Pivot the line around counts_empty so the empty plate keeps reading what it read.
  const int32_t line_at_empty_mg = lineMilligrams(counts_empty);
  config_.slope_ug_per_count = slope;
  config_.offset_mg = line_at_empty_mg + calibration_mg_ - slopeMilligrams(slope, counts_empty);
  // The tare point was taken on the old slope: it no longer reads zero.
  zero_mg_ = 0;
  tared_ = false;
  return true;
}

void LoadCell::tare(uint16_t counts) {
  zero_mg_ = -lineMilligrams(counts);  // thesis ZEROLIZE_VALUE
  tared_ = true;
}

void LoadCell::tareQ4(uint16_t counts_q4) {
  zero_mg_ = -(slopeMilligramsQ4(config_.slope_ug_per_count, counts_q4) + config_.offset_mg -
               calibration_mg_);
  tared_ = true;
}

int32_t LoadCell::forceMilligramsQ4(uint16_t counts_q4) const {
  return slopeMilligramsQ4(config_.slope_ug_per_count, counts_q4) + config_.offset_mg - calibration_mg_ +
         zero_mg_;
}

int32_t LoadCell::forceMilligrams(uint16_t counts) const { return lineMilligrams(counts) + zero_mg_; }

int16_t LoadCell::forceGrams(uint16_t counts) const { return saturateGrams(forceMilligrams(counts)); }

LoadCellStatus LoadCell::check(uint16_t counts) const {
  const uint16_t margin = config_.rail_margin_counts;
  if (counts <= margin || counts >= static_cast<uint16_t>(config_.adc_max_counts - margin))
    return LoadCellStatus::kImplausible;
  const int32_t limit_mg = static_cast<int32_t>(config_.overload_g) * 1000;
  const int32_t weight_mg = -lineMilligrams(counts) - static_cast<int32_t>(config_.plate_g) * 1000;
  if (absolute(weight_mg) > limit_mg) return LoadCellStatus::kOverload;
  if (tared_ && absolute(forceMilligrams(counts)) > limit_mg) return LoadCellStatus::kOverload;
  return LoadCellStatus::kOk;
}

}  // namespace tc
