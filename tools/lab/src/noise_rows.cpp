// The noise floor's rows (see noise.hpp): the logged conditions whose contrasts are regressed out,
// and the sweeps whose neighbouring rows give the contrasts.
#include "noise_rows.hpp"

#include "csv_reader.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <string>
#include <utility>

namespace lab::noise_rows {

namespace {

constexpr double kHeldShare = 0.3;  // more repeated readings than this: held between updates

bool contains(const std::string& s, const char* word) { return s.find(word) != std::string::npos; }

// A column that may be computed from the force reading (a thrust in other units, an
// efficiency in g/W): regressing it out would take the noise with it.
bool mayHoldForce(const std::string& name) {
  const std::string n = csv::lower(name);
  for (const char* w : {"force", "thrust", "weight", "efficien", "lift", "load", "mass"})
    if (contains(n, w)) return true;
  return false;
}

}  // namespace

// The logged conditions whose contrasts are regressed out: every other numeric column logged on
// every row and not constant.
std::vector<std::size_t> conditionColumns(const Dataset& d) {
  std::vector<std::size_t> out;
  for (std::size_t c = 0; c < d.names.size(); ++c) {
    const std::string& n = d.names[c];
    if (n == "pwm_us" || n == "force_g" || n == "run" || mayHoldForce(n)) continue;
    const auto& v = d.columns[c];
    bool finite = true, varies = false;
    for (double x : v) {
      finite = finite && std::isfinite(x);
      varies = varies || x != v.front();
    }
    if (finite && varies) out.push_back(c);
  }
  return out;
}

namespace {

// The sweep direction of each row: the sign of the PWM's change in logging order within its run
// (a repeated set point keeps the direction it had), times the `dir` column's sign when logged,
// so a sweep restarting from the bottom, or a logged turn, starts a new sweep.
std::vector<int> directions(const Dataset& d) {
  std::vector<int> sign(d.rows(), 0);
  const auto& pwm = d.col("pwm_us");
  const std::vector<double>* dir = d.has("dir") ? &d.col("dir") : nullptr;
  std::map<int, std::size_t> last;      // run -> its previous row
  std::map<int, int> last_sign;         // run -> the direction so far
  std::map<int, std::vector<std::size_t>> unsigned_rows;  // rows before the run's first change
  for (std::size_t i = 0; i < d.rows(); ++i) {
    const int r = d.run[i];
    const auto it = last.find(r);
    int s = 0;
    if (it != last.end() && pwm[i] != pwm[it->second]) s = pwm[i] > pwm[it->second] ? 1 : -1;
    if (s == 0) s = last_sign[r];
    if (s != 0 && last_sign[r] == 0)
      for (std::size_t j : unsigned_rows[r]) sign[j] = s;
    if (s == 0) unsigned_rows[r].push_back(i);
    sign[i] = s;
    last_sign[r] = s;
    last[r] = i;
  }
  if (dir)
    for (std::size_t i = 0; i < d.rows(); ++i)
      if (std::isfinite((*dir)[i]) && (*dir)[i] < 0) sign[i] = 2 + sign[i];  // a turn the log says: its own sweep
  return sign;
}

// Rows that repeat the previous row's force exactly, in logging order within a run: when most
// do, the logger held the reading between updates, and one row per update is one reading.
std::vector<bool> heldReadings(const Dataset& d, bool& held) {
  const auto& f = d.col("force_g");
  std::vector<bool> repeat(d.rows(), false);
  std::map<int, std::size_t> last;
  std::size_t repeats = 0;
  for (std::size_t i = 0; i < d.rows(); ++i) {
    const auto it = last.find(d.run[i]);
    repeat[i] = it != last.end() && f[i] == f[it->second];
    repeats += repeat[i] ? 1 : 0;
    last[d.run[i]] = i;
  }
  held = static_cast<double>(repeats) > kHeldShare * static_cast<double>(d.rows());
  if (!held) std::fill(repeat.begin(), repeat.end(), false);
  return repeat;
}

}  // namespace

// The rows of each sweep (a run's rows in logging order, cut where the direction turns), sorted
// by PWM, then by time or logging order; held repeats of a reading left out.
std::vector<std::vector<std::size_t>> neighbourGroups(const Dataset& d, bool& held) {
  const auto& pwm = d.col("pwm_us");
  const std::vector<double>* t = d.has("t_s") ? &d.col("t_s") : nullptr;
  const std::vector<int> sign = directions(d);
  const std::vector<bool> repeat = heldReadings(d, held);
  std::map<std::pair<int, int>, std::vector<std::size_t>> groups;
  std::map<int, std::pair<int, int>> segment;  // run -> (segment, its direction)
  for (std::size_t i = 0; i < d.rows(); ++i) {
    auto [it, fresh] = segment.try_emplace(d.run[i], 0, sign[i]);
    if (!fresh && sign[i] != it->second.second) it->second = {it->second.first + 1, sign[i]};
    if (!repeat[i]) groups[{d.run[i], it->second.first}].push_back(i);
  }
  std::vector<std::vector<std::size_t>> out;
  for (auto& [key, rows] : groups) {
    std::stable_sort(rows.begin(), rows.end(), [&](std::size_t a, std::size_t b) {
      if (pwm[a] != pwm[b]) return pwm[a] < pwm[b];
      return t && std::isfinite((*t)[a]) && std::isfinite((*t)[b]) ? (*t)[a] < (*t)[b] : a < b;
    });
    out.push_back(std::move(rows));
  }
  return out;
}

}  // namespace lab::noise_rows
