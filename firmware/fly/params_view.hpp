// What fly's `param` commands and its start-up print about the parameters (params.hpp). It
// only prints; deciding is params.cpp's.
#pragma once
#include <stdint.h>

#include "params.hpp"

namespace fly {
namespace params_view {

// "angle_kp 800  # mN m/rad, 0..10000" (`param list`, a parameter file's line), then
// "; unsaved (reset gives 900)" when a reset would change it; `detailed` (`param get`) adds
// the default and what it does.
void row(uint8_t index, int32_t value, int32_t on_reset, bool detailed);
void unknown(const char* name);
void armedRefused(const tc::ParamDef& d);
void valueRefused(const tc::ParamDef& d, tc::ParamParse why, const char* text);
void ruleBroken(const tc::ParamCheck& check, const ParamValues& v);
// The mode in `v` could not be taken (generic: its slot has no valid record).
void modeNotTaken(const FlyApp& app, const ParamValues& v);
// Start-up and `param load`: what flies and why.
void loaded(const SavedState& s);
void saved(const tc::ParamsWrite& w);
void defaultsSet();
void status(uint8_t unsaved, const SavedState& s);

}  // namespace params_view
}  // namespace fly
