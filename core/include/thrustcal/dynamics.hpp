// Each motor's force response in time (issue 26), as gather_store's `dyn` measures it and the
// records keep it, and the bench's own response that the measurement separates from it.
//
// The motor: its speed follows the ESC's command as a first-order lag, and thrust goes with the
// speed squared. The time constant depends on the operating point: around a speed w,
// tau = J / (Kt Ke / R + dQ/dw), and the propeller's dQ/dw grows with w, i.e. with sqrt(force).
// So per direction (spin-up, spin-down: an ESC without active braking only has the propeller's
// drag to slow the motor) the model is the law
//
//     1 / tau(F) = a + b * sqrt(F)
//
// fitted to the time constants measured at several operating points. A record keeps the law as
// its values at the lightest and the heaviest point measured (MotorDynamics), which is what a
// user reads back (`show`) and what the law's two coefficients follow from.
//
// The bench: the load cell's amplifier and RC low-pass lie between the motor's force and what
// the ADC reads. They are identified once per bench (`dyn cell`: a weight lifted off the plate
// at once, a force step with no motor in it) as `stages` equal first-order stages with one time
// constant (BenchResponse, kept with the board settings), and the motor's own lag is what the
// step logs show beyond them (thrustcal/dynamics_fit.hpp). docs/model_v2.md ("Dynamics")
// explains the model and the figures.
#pragma once
#include <stdint.h>

namespace tc {

// Time constants a record may hold (0.1 ms units): 5 ms .. 2 s. Outside, the measurement or the
// record is wrong (a small motor's speed lag is tens of milliseconds, a large one's hundreds).
constexpr uint16_t kDynTauMin01ms = 50;
constexpr uint16_t kDynTauMax01ms = 20000;
// Operating points a measurement may combine.
constexpr uint8_t kDynMaxPoints = 8;
// Bench response: 1..4 equal stages of 1 ms .. 2 s.
constexpr uint8_t kBenchMaxStages = 4;
constexpr uint16_t kBenchTauMin01ms = 10;
constexpr uint16_t kBenchTauMax01ms = 20000;

// One motor's dynamics (13 bytes in the v2 record, record_v2.hpp). points == 0: none measured.
struct MotorDynamics {
  uint8_t points = 0;             // operating points measured, 1..kDynMaxPoints; 0 = none
  uint16_t lo_dg = 0;             // lightest operating point, decigrams
  uint16_t hi_dg = 0;             // heaviest (== lo_dg when one point was measured)
  uint16_t up_lo_01ms = 0;        // spin-up time constant at lo_dg, 0.1 ms
  uint16_t up_hi_01ms = 0;        // ... at hi_dg
  uint16_t down_lo_01ms = 0;      // spin-down time constant at lo_dg
  uint16_t down_hi_01ms = 0;      // ... at hi_dg

  bool isPresent() const { return points != 0; }
  // The fields are in range: points 1..8, 0 < lo <= hi, every time constant in
  // kDynTauMin01ms..kDynTauMax01ms, and lo == hi exactly when the two ends agree (one point).
  bool isValid() const;
  void clear() { *this = MotorDynamics(); }
  // The law's time constant at `force_g` (seconds; the law extrapolates beyond the points
  // measured, kept within the stored range's bounds 5 ms .. 2 s). Not present: 0.
  float tauUpS(float force_g) const;
  float tauDownS(float force_g) const;
};

bool operator==(const MotorDynamics& a, const MotorDynamics& b);
inline bool operator!=(const MotorDynamics& a, const MotorDynamics& b) { return !(a == b); }

// The bench's load-cell path as `stages` equal first-order low-pass stages.
struct BenchResponse {
  uint8_t stages = 0;     // 1..kBenchMaxStages; 0 = not identified
  uint16_t tau_01ms = 0;  // each stage's time constant, 0.1 ms

  bool isPresent() const { return stages != 0; }
  bool isValid() const {
    return stages >= 1 && stages <= kBenchMaxStages && tau_01ms >= kBenchTauMin01ms &&
           tau_01ms <= kBenchTauMax01ms;
  }
  float tauS() const { return static_cast<float>(tau_01ms) * 1e-4f; }
  // Mean delay of the path (its step response's first moment): stages * tau.
  float delayS() const { return static_cast<float>(stages) * tauS(); }
};

inline bool operator==(const BenchResponse& a, const BenchResponse& b) {
  return a.stages == b.stages && a.tau_01ms == b.tau_01ms;
}

// Seconds <-> the records' 0.1 ms units, rounded and saturated to 0..65535.
uint16_t secondsTo01ms(float seconds);

}  // namespace tc
