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

}  // namespace lab
