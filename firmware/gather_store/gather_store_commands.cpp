// gather_store's console commands: one table in flash (fw::Command rows, firmware/common/
// shell.hpp). Names, argument ranges, which commands strict mode guards, and the help lines
// all come from here; `help` prints this table and docs/gather_store.md's command list is
// checked against that output (tests/firmware/gather_store/test_gather_store_docs.cpp).
//
// Guarded (kCmdGuarded: with strict on, only checksummed lines run them): the commands that
// spin a motor or write the EEPROM, i.e. sweep, store 1|2|v2, erase, divider R1 R2, dyn and
// dyn cell.
#include "console.hpp"
#include "eeprom_console.hpp"
#include "gather_store_app.hpp"
#include "shell.hpp"

namespace gs {

// The handlers: each turns the parsed arguments into one GatherStoreApp command.
struct GatherStoreCommands {
  using Args = fw::ArgValues;
  static void help(GatherStoreApp& app, const Args&) { app.cmdHelp(); }
  static void motor(GatherStoreApp& app, const Args& a) {
    app.cmdMotor(static_cast<uint8_t>(a[0]));
  }
  static void plate(GatherStoreApp& app, const Args& a) {
    app.cmdPlate(static_cast<int16_t>(a[0]));
  }
  static void weigh(GatherStoreApp& app, const Args&) { app.cmdWeigh(); }
  static void cal(GatherStoreApp& app, const Args& a) { app.cmdCal(static_cast<int16_t>(a[0])); }
  static void tare(GatherStoreApp& app, const Args&) { app.cmdTare(); }
  static void span(GatherStoreApp& app, const Args& a) {
    app.cmdSpan(static_cast<int16_t>(a[0]));
  }
  static void range(GatherStoreApp& app, const Args& a) {
    app.cmdRange(static_cast<uint16_t>(a[0]), static_cast<uint16_t>(a[1]));
  }
  static void step(GatherStoreApp& app, const Args& a) {
    app.cmdStep(static_cast<uint16_t>(a[0]));
  }
  static void settleMs(GatherStoreApp& app, const Args& a) {
    app.cmdSettle(static_cast<uint16_t>(a[0]));
  }
  static void settleAuto(GatherStoreApp& app, const Args&) { app.cmdSettleAuto(); }
  static void sweep(GatherStoreApp& app, const Args&) { app.cmdSweep(); }
  static void store1(GatherStoreApp& app, const Args&) { app.cmdStore(1); }
  static void store2(GatherStoreApp& app, const Args&) { app.cmdStore(2); }
  static void storeV2(GatherStoreApp& app, const Args&) { app.cmdStoreV2(); }
  static void show(GatherStoreApp& app, const Args&) { app.cmdShow(); }
  static void erase(GatherStoreApp& app, const Args&) { app.cmdErase(); }
  static void status(GatherStoreApp& app, const Args&) { app.cmdStatus(); }
  static void eeprom(GatherStoreApp&, const Args& a) {
    if (a[0] == 0) {
      fw::eepromCrc();
    } else {
      fw::eepromDump();
    }
  }
  static void dividerShow(GatherStoreApp& app, const Args&) { app.cmdDividerShow(); }
  static void divider(GatherStoreApp& app, const Args& a) {
    app.cmdDivider(static_cast<uint32_t>(a[0]), static_cast<uint32_t>(a[1]));
  }
  static void strict(GatherStoreApp& app, const Args& a) { app.reader_.strictCommand(a[0] == 0); }
  static void dynCell(GatherStoreApp& app, const Args&) { app.cmdDynCell(); }
  static void dyn(GatherStoreApp& app, const Args&) { app.cmdDyn(); }
};

namespace {

using C = GatherStoreCommands;
using fw::kCmdGuarded;

// Names, argument specs and help lines: all in flash.
const char kHelp[] TC_FLASH = "help";
const char kMotor[] TC_FLASH = "motor";
const char kPlate[] TC_FLASH = "plate";
const char kWeigh[] TC_FLASH = "weigh";
const char kCal[] TC_FLASH = "cal";
const char kTare[] TC_FLASH = "tare";
const char kSpan[] TC_FLASH = "span";
const char kRange[] TC_FLASH = "range";
const char kStep[] TC_FLASH = "step";
const char kSettle[] TC_FLASH = "settle";
const char kSweep[] TC_FLASH = "sweep";
const char kStore[] TC_FLASH = "store";
const char kShow[] TC_FLASH = "show";
const char kErase[] TC_FLASH = "erase";
const char kStatus[] TC_FLASH = "status";
const char kEeprom[] TC_FLASH = "eeprom";
const char kDivider[] TC_FLASH = "divider";
const char kStrict[] TC_FLASH = "strict";
const char kDyn[] TC_FLASH = "dyn";

const char kN[] TC_FLASH = "N";
const char kG[] TC_FLASH = "G";
const char kW[] TC_FLASH = "W";
const char kMin[] TC_FLASH = "MIN";
const char kMax[] TC_FLASH = "MAX";
const char kUs[] TC_FLASH = "US";
const char kMs[] TC_FLASH = "MS";
const char kR1[] TC_FLASH = "R1";
const char kR2[] TC_FLASH = "R2";
const char kWordAuto[] TC_FLASH = "auto";
const char kWord1[] TC_FLASH = "1";
const char kWord2[] TC_FLASH = "2";
const char kWordV2[] TC_FLASH = "v2";
const char kWordsEeprom[] TC_FLASH = "crc|dump";
const char kWordsOnOff[] TC_FLASH = "on|off";
const char kWordCell[] TC_FLASH = "cell";

static_assert(tc::LoadCellConfig().overload_g == tc::kKnownWeightMaxG, "cal/span up to the overload");
constexpr int32_t kSlotMax = tc::kMotorSlots - 1;
constexpr int32_t kDividerMax = static_cast<int32_t>(tc::kDividerMaxOhm);

const fw::ArgSpec kArgSlot[] TC_FLASH = {{kN, nullptr, 0, kSlotMax}};
const fw::ArgSpec kArgPlate[] TC_FLASH = {{kG, nullptr, 0, tc::kPlateMaxG}};
const fw::ArgSpec kArgKnown[] TC_FLASH = {{kW, nullptr, 1, tc::kKnownWeightMaxG}};
const fw::ArgSpec kArgRange[] TC_FLASH = {{kMin, nullptr, tc::kSweepPwmLowestUs, tc::kSweepPwmHighestUs - 1},
                                           {kMax, nullptr, tc::kSweepPwmLowestUs + 1, tc::kSweepPwmHighestUs}};
const fw::ArgSpec kArgStep[] TC_FLASH = {{kUs, nullptr, tc::kSweepStepMinUs, tc::kSweepStepMaxUs}};
const fw::ArgSpec kArgSettle[] TC_FLASH = {{kMs, nullptr, tc::kSweepSettleMinMs, tc::kSweepSettleMaxMs}};
const fw::ArgSpec kArgAuto[] TC_FLASH = {{kWordAuto, kWordAuto, 0, 0}};
const fw::ArgSpec kArgStore1[] TC_FLASH = {{kWord1, kWord1, 0, 0}};
const fw::ArgSpec kArgStore2[] TC_FLASH = {{kWord2, kWord2, 0, 0}};
const fw::ArgSpec kArgStoreV2[] TC_FLASH = {{kWordV2, kWordV2, 0, 0}};
const fw::ArgSpec kArgEeprom[] TC_FLASH = {{kWordsEeprom, kWordsEeprom, 0, 0}};
const fw::ArgSpec kArgDivider[] TC_FLASH = {{kR1, nullptr, 0, kDividerMax},
                                             {kR2, nullptr, 0, kDividerMax}};
const fw::ArgSpec kArgOnOff[] TC_FLASH = {{kWordsOnOff, kWordsOnOff, 0, 0}};
const fw::ArgSpec kArgCell[] TC_FLASH = {{kWordCell, kWordCell, 0, 0}};

// Help lines. The numbers they quote are the constants' (checked below); the ranges of the
// arguments are appended by fw::printHelp from the specs above.
static_assert(kForceWindow == 201, "weigh's help quotes the median of 201");
static_assert(kDefaultSettleCapMs == 500, "settle auto's help quotes the cap");
static_assert(SweepSettings().plate_g == 60 && SweepSettings().step_us == 10 &&
                  SweepSettings().pwm_min_us == 1000 && SweepSettings().pwm_max_us == 1800,
              "the defaults the help lines quote");
const char kHelpHelp[] TC_FLASH = "this list";
const char kHelpMotor[] TC_FLASH = "select motor slot N: ESC output and EEPROM record";
const char kHelpPlate[] TC_FLASH = "plate weight in g, default 60";
const char kHelpWeigh[] TC_FLASH = "weight on the plate (median of 201 readings)";
const char kHelpCal[] TC_FLASH = "calibrate: motor + propeller weigh W g; also tares";
const char kHelpTare[] TC_FLASH = "zerolize: force reads 0 g now (motor mounted, stopped)";
const char kHelpSpan[] TC_FLASH = "optional gain: after tare put W g on the plate,\nthen span W";
const char kHelpRange[] TC_FLASH = "sweep PWM range in us,\ndefault 1000 1800";
const char kHelpStep[] TC_FLASH = "sweep step in us, default 10";
const char kHelpSettleMs[] TC_FLASH = "wait per step in ms (thesis: 200); also the cap\nof settle auto";
const char kHelpSettleAuto[] TC_FLASH = "next step once the force stops changing\n(default, cap 500 ms)";
const char kHelpSweep[] TC_FLASH = "run the sweep, stream CSV; any key aborts (motor -> 1000 us)";
const char kHelpStore1[] TC_FLASH = "store the last sweep as curve 1 (+ start voltage, sag offsets)";
const char kHelpStore2[] TC_FLASH = "store the last sweep as curve 2 (another battery voltage)";
const char kHelpStoreV2[] TC_FLASH = "fit model v2 (effective voltage) to the last sweep and store it;\n"
                      "a slot's v2 model from another voltage (>= 0.5 V) is refined";
const char kHelpShow[] TC_FLASH = "what the selected slot's EEPROM record holds (v1 or v2)";
const char kHelpErase[] TC_FLASH = "mark the selected slot not calibrated (v1 and both v2 copies)";
const char kHelpStatus[] TC_FLASH = "settings, live force and battery, last sweep, stack";
const char kHelpEeprom[] TC_FLASH = "EEPROM CRC-16 per slot and whole, or all of it as Intel HEX";
const char kHelpDividerShow[] TC_FLASH = "the battery divider (read_run flies with it too)";
const char kHelpDivider[] TC_FLASH = "set it in ohm: R1 pack-A1, R2 A1-ground,\ndefault 100000 47000 (15.638 V)";
const char kHelpStrict[] TC_FLASH = "sweep, store, erase, divider R1 R2 and dyn need a checksum\n(host clients)";
const char kHelpDyn[] TC_FLASH = "the motor's dynamics: force steps up and down at 5 points,\n"
                                 "step logs streamed; stored with its model v2";
const char kHelpDynCell[] TC_FLASH = "the load cell's own response: lift a weight off the plate\n"
                                     "(once per bench; stored with the board settings)";
static_assert(tc::kV2MinVoltageGapMv == 500, "store v2's help quotes 0.5 V");

const fw::Command<GatherStoreApp> kCommands[] TC_FLASH = {
    {{kHelp, nullptr, 0, 0, 0, kHelpHelp}, C::help},
    {{kMotor, kArgSlot, 1, 1, 0, kHelpMotor}, C::motor},
    {{kPlate, kArgPlate, 1, 1, 0, kHelpPlate}, C::plate},
    {{kWeigh, nullptr, 0, 0, 0, kHelpWeigh}, C::weigh},
    {{kCal, kArgKnown, 1, 1, 0, kHelpCal}, C::cal},
    {{kTare, nullptr, 0, 0, 0, kHelpTare}, C::tare},
    {{kSpan, kArgKnown, 1, 1, 0, kHelpSpan}, C::span},
    {{kRange, kArgRange, 2, 2, 0, kHelpRange}, C::range},
    {{kStep, kArgStep, 1, 1, 0, kHelpStep}, C::step},
    {{kSettle, kArgSettle, 1, 1, 0, kHelpSettleMs}, C::settleMs},
    {{kSettle, kArgAuto, 1, 1, 0, kHelpSettleAuto}, C::settleAuto},
    {{kSweep, nullptr, 0, 0, kCmdGuarded, kHelpSweep}, C::sweep},
    {{kStore, kArgStore1, 1, 1, kCmdGuarded, kHelpStore1}, C::store1},
    {{kStore, kArgStore2, 1, 1, kCmdGuarded, kHelpStore2}, C::store2},
    {{kStore, kArgStoreV2, 1, 1, kCmdGuarded, kHelpStoreV2}, C::storeV2},
    {{kShow, nullptr, 0, 0, 0, kHelpShow}, C::show},
    {{kErase, nullptr, 0, 0, kCmdGuarded, kHelpErase}, C::erase},
    {{kStatus, nullptr, 0, 0, 0, kHelpStatus}, C::status},
    {{kEeprom, kArgEeprom, 1, 1, 0, kHelpEeprom}, C::eeprom},
    {{kDivider, nullptr, 0, 0, 0, kHelpDividerShow}, C::dividerShow},
    {{kDivider, kArgDivider, 2, 2, kCmdGuarded, kHelpDivider}, C::divider},
    {{kDyn, kArgCell, 1, 1, kCmdGuarded, kHelpDynCell}, C::dynCell},
    {{kDyn, nullptr, 0, 0, kCmdGuarded, kHelpDyn}, C::dyn},
    {{kStrict, kArgOnOff, 1, 1, 0, kHelpStrict}, C::strict},
};

}  // namespace

void GatherStoreApp::runCommand(char* line, const fw::LineContext& context) {
  fw::dispatch(*this, kCommands, line, context);
}

void GatherStoreApp::cmdHelp() {
  fw::printHelp(kCommands);
  fw::say(TC_FLASH_TEXT("lines: CR, LF or CRLF, at most "));
  fw::printUint(fw::kLineMax);
  fw::sayLine(TC_FLASH_TEXT(" characters; optional checksum *HH = XOR"));
  fw::sayLine(TC_FLASH_TEXT("of the line before '*'; a damaged line is rejected whole (docs/console.md)"));
}

}  // namespace gs
