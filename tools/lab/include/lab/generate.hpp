// Synthetic bench logs from the plant model (tools/plant) with one hidden effect switched on,
// for the README walkthrough and the lab's tests. The physics is the plant's; the generator
// only chooses the conditions (voltages, motors, air, time) and adds the load-cell noise.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "lab/dataset.hpp"

namespace lab {

struct GenerateOptions {
  std::string hidden = "none";  // see hiddenEffects()
  double noise_g = 1.0;         // load-cell noise, one standard deviation, grams
  uint64_t seed = 1;
  std::string preset = "kv1100_9x4.7";
  double log_hz = 0;    // 0: one row per PWM point at the end of its settling; else rows at this rate
  double settle_s = 0;  // time per PWM point; 0: the hidden effect's default (0.5 s, 2 s)
  double noise_lag1 = 0;  // the noise's lag-1 autocorrelation between successive rows (AR(1)), 0..0.95
  bool bench_filter = false;  // read the force through the plant's load-cell low-pass (three 30 ms stages)
};

struct HiddenEffectInfo {
  std::string name;
  std::string description;   // what the generator does
  std::string start_model;   // a model that lacks it
  std::string right_effect;  // what fixes it
  std::string responsible;   // the variable a diagnosis should name
};
const std::vector<HiddenEffectInfo>& hiddenEffects();

// Throws std::invalid_argument for an unknown hidden effect.
Dataset generate(const GenerateOptions& options, std::vector<std::string>* comments = nullptr);

// The step log's truth (hidden effect `lag`): each motor's rotor-speed time constants for the
// log's 100 us steps, as the plant measures them (plant::stepTimeConstant_s, what `thrustcal plant
// step` prints for a stock motor).
struct StepTruth {
  int motor = 0;
  double from_us = 0, to_us = 0, bus_v = 0;
  double tau_up_s = 0, tau_down_s = 0;
};
std::vector<StepTruth> stepTruth(const GenerateOptions& options);

// The same measurements as an RCbenchmark / Tyto Robotics export writes them (the layouts of
// the RCbenchmark software's CSV logs, as published logs show them): every line ends with a
// comma, `µs` in UTF-8, units in parentheses, empty servo columns, an `App message` text column
// ("Tare done" on the first row), the time from 0. Series 1520: time, ESC and servo signals,
// thrust, voltage, current, speeds, power, efficiency. Series 1580/1585: also accelerometer,
// torque, mechanical power and efficiencies, vibration.
struct StandLayout {
  std::string series = "1585";     // "1520" or "1585" (1580 writes the same columns)
  std::string thrust_unit = "N";   // N, kgf, gf, lbf, ozf
  std::string torque_unit = "N·m"; // N·m or ozf·in (1585)
  bool negative_thrust = false;    // a stand mounted pulling the other way
  bool tare_message = true;
};
// Throws std::invalid_argument for an unknown series or unit.
std::string toStandCsv(const Dataset& data, const StandLayout& layout);

}  // namespace lab
