// fly's parameter lines (params_view.hpp).
#include "params_view.hpp"

#include "fly_app.hpp"
#include "slot_report.hpp"

namespace fly {
namespace params_view {

namespace {

using fw::newline;
using fw::say;
using fw::sayLine;

tc::ParamDef rowOf(uint8_t index) { return tc::paramRow(kParamRows, index); }

void sayValue(const tc::ParamDef& d, int32_t value) {
  char text[tc::kParamTextMax];
  tc::formatParamValue(d, value, text);
  hal::Uart::print(text);
}

// "0..10000", "0 (off) or 1001..2000", "-1.0000..1.0000", "plus|x|seesaw"
void sayRange(const tc::ParamDef& d) {
  if (d.words != nullptr) {
    hal::Uart::printP(d.words);
    return;
  }
  if (d.flags & tc::kParamZeroIsOff) say(TC_FLASH_TEXT("0 (off) or "));
  sayValue(d, d.min);
  say(TC_FLASH_TEXT(".."));
  sayValue(d, d.max);
}

// "angle_kp 800"
void sayNameValue(const tc::ParamDef& d, int32_t value) {
  hal::Uart::printP(d.name);
  hal::Uart::write(' ');
  sayValue(d, value);
}

// " (motor 3's slot, copy B, sequence 5)"
void sayWhere(uint8_t host, uint8_t copy, uint16_t sequence) {
  say(TC_FLASH_TEXT(" (motor "));
  fw::printUint(host);
  say(TC_FLASH_TEXT("'s slot, "));
  fw::sayCopy(copy);
  say(TC_FLASH_TEXT(", sequence "));
  fw::printUint(sequence);
  hal::Uart::write(')');
}

void sayNoRoom() {
  say(TC_FLASH_TEXT("all four slots hold thesis (v1) records, which fill the EEPROM"));
}

// Why the saved copy is not flown (kOtherLayout, kCannotBeRight).
void sayWhyNot(const SavedState& s) {
  if (s.how == ParamLoad::kOtherLayout) {
    say(TC_FLASH_TEXT("saved by a fly with parameter layout "));
    fw::printUint(s.layout);
    say(TC_FLASH_TEXT(" (this one has "));
    fw::printUint(kParamLayout);
    hal::Uart::write(')');
    return;
  }
  say(TC_FLASH_TEXT("the saved copy cannot be right ("));
  const tc::ParamDef d = rowOf(s.check.row);
  if (s.check.fault == tc::ParamFault::kBadLength) {
    say(TC_FLASH_TEXT("its size is not this layout's"));
  } else if (s.check.fault == tc::ParamFault::kNotBelowNext) {
    sayNameValue(d, s.value[0]);
    say(TC_FLASH_TEXT(" not below "));
    sayNameValue(rowOf(static_cast<uint8_t>(s.check.row + 1)), s.value[1]);
  } else {
    sayNameValue(d, s.value[0]);
    say(TC_FLASH_TEXT("; allowed "));
    sayRange(d);
  }
  hal::Uart::write(')');
}

}  // namespace

void row(uint8_t index, int32_t value, int32_t on_reset, bool detailed) {
  const tc::ParamDef d = rowOf(index);
  sayNameValue(d, value);
  say(TC_FLASH_TEXT("  # "));
  if (tc::flashByte(d.unit) != 0) {
    hal::Uart::printP(d.unit);
    say(TC_FLASH_TEXT(", "));
  }
  sayRange(d);
  if (detailed) {
    say(TC_FLASH_TEXT(", default "));
    sayValue(d, d.def);
    say(TC_FLASH_TEXT(": "));
    hal::Uart::printP(d.help);
  }
  if (value != on_reset) {
    say(TC_FLASH_TEXT("; unsaved (reset gives "));
    sayValue(d, on_reset);
    hal::Uart::write(')');
  }
  newline();
}

void unknown(const char* name) {
  say(TC_FLASH_TEXT("error: no parameter \""));
  hal::Uart::print(name);
  sayLine(TC_FLASH_TEXT("\"; param list shows them"));
}

void armedRefused(const tc::ParamDef& d) {
  say(TC_FLASH_TEXT("error: armed: "));
  hal::Uart::printP(d.name);
  sayLine(TC_FLASH_TEXT(" could make the motors jump; disarm first (crash_deg may change armed)"));
}

void valueRefused(const tc::ParamDef& d, tc::ParamParse why, const char* text) {
  say(TC_FLASH_TEXT("error: "));
  hal::Uart::printP(d.name);
  if (why == tc::ParamParse::kNotAWord) {
    say(TC_FLASH_TEXT(" is one of "));
  } else if (why == tc::ParamParse::kNotANumber && d.decimals == 0) {
    say(TC_FLASH_TEXT(" takes a whole number "));
  } else if (why == tc::ParamParse::kNotANumber) {
    say(TC_FLASH_TEXT(" takes a number with at most "));
    fw::printUint(d.decimals);
    say(TC_FLASH_TEXT(" decimals, "));
  } else {
    say(TC_FLASH_TEXT(" must be "));
  }
  sayRange(d);
  if (d.words == nullptr && tc::flashByte(d.unit) != 0) {
    hal::Uart::write(' ');
    hal::Uart::printP(d.unit);
  }
  say(TC_FLASH_TEXT(", got \""));
  hal::Uart::print(text);
  sayLine(TC_FLASH_TEXT("\"; nothing changed"));
}

void ruleBroken(const tc::ParamCheck& check, const ParamValues& v) {
  const tc::ParamDef d = rowOf(check.row);
  say(TC_FLASH_TEXT("error: "));
  sayNameValue(d, v[check.row]);
  if (check.fault == tc::ParamFault::kNotBelowNext) {
    say(TC_FLASH_TEXT(" must be below "));
    sayNameValue(rowOf(static_cast<uint8_t>(check.row + 1)), v[check.row + 1]);
    say(TC_FLASH_TEXT(" unless that is 0"));
  } else {
    say(TC_FLASH_TEXT(" is outside "));
    sayRange(d);
  }
  sayLine(TC_FLASH_TEXT("; nothing changed"));
}

void modeNotTaken(const FlyApp& app, const ParamValues& v) {
  const uint8_t slot = static_cast<uint8_t>(v[kParamGenericSlot]);
  say(TC_FLASH_TEXT("error: mode generic not taken: slot "));
  fw::printUint(slot);
  say(TC_FLASH_TEXT(" is "));
  fw::sayRecordStatus(app.motors().motor(slot));
  say(TC_FLASH_TEXT("; mode stays "));
  sayValue(rowOf(kParamMode), static_cast<int32_t>(app.output().mode()));
  newline();
}

void loaded(const SavedState& s) {
  say(TC_FLASH_TEXT("params: "));
  switch (s.how) {
    case ParamLoad::kLoaded:
      fw::printUint(kParamCount);
      say(TC_FLASH_TEXT(" loaded from the EEPROM"));
      sayWhere(s.where.host, s.where.copy, s.where.sequence);
      newline();
      return;
    case ParamLoad::kNone:
      sayLine(TC_FLASH_TEXT("none saved: the defaults (param set NAME VALUE, then param save)"));
      return;
    case ParamLoad::kNoRoom:
      say(TC_FLASH_TEXT("none, and no room to save any: "));
      sayNoRoom();
      sayLine(TC_FLASH_TEXT("; the defaults"));
      return;
    default:
      sayWhyNot(s);
      sayLine(TC_FLASH_TEXT(": the defaults; set them again and param save (or thrustcal board params push)"));
      return;
  }
}

void saved(const tc::ParamsWrite& w) {
  switch (w.status) {
    case tc::ParamsWriteStatus::kWritten:
      say(TC_FLASH_TEXT("param: saved "));
      fw::printUint(kParamCount);
      say(TC_FLASH_TEXT(" parameters"));
      sayWhere(w.host, w.copy, w.sequence);
      newline();
      return;
    case tc::ParamsWriteStatus::kUnchanged:
      say(TC_FLASH_TEXT("param: nothing to save: the EEPROM holds these values"));
      sayWhere(w.host, w.copy, w.sequence);
      newline();
      return;
    case tc::ParamsWriteStatus::kNoRoom:
      say(TC_FLASH_TEXT("error: no room: "));
      sayNoRoom();
      sayLine(TC_FLASH_TEXT("; store a motor as model v2 or erase a slot (gather_store), then save again; "
                            "nothing saved"));
      return;
    case tc::ParamsWriteStatus::kVerifyFailed:
      say(TC_FLASH_TEXT("error: the new copy did not read back"));
      sayWhere(w.host, w.copy, w.sequence);
      sayLine(TC_FLASH_TEXT(": the EEPROM may be worn; the previous saved parameters stay"));
      return;
    default:
      sayLine(TC_FLASH_TEXT("error: the record does not fit its room; nothing saved"));
      return;
  }
}

void defaultsSet() { sayLine(TC_FLASH_TEXT("param: the defaults (not saved: param save keeps them)")); }

void status(uint8_t unsaved, const SavedState& s) {
  say(TC_FLASH_TEXT("params: "));
  if (unsaved != 0) {
    fw::printUint(unsaved);
    sayLine(TC_FLASH_TEXT(" unsaved (param list marks them; param save keeps them)"));
    return;
  }
  switch (s.how) {
    case ParamLoad::kLoaded:
      say(TC_FLASH_TEXT("as saved"));
      sayWhere(s.where.host, s.where.copy, s.where.sequence);
      newline();
      return;
    case ParamLoad::kNone:
      sayLine(TC_FLASH_TEXT("the defaults, none saved"));
      return;
    case ParamLoad::kNoRoom:
      say(TC_FLASH_TEXT("the defaults, no room to save: "));
      sayNoRoom();
      newline();
      return;
    default:
      say(TC_FLASH_TEXT("the defaults: "));
      sayWhyNot(s);
      newline();
      return;
  }
}

}  // namespace params_view
}  // namespace fly
