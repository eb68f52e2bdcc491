// `thrustcal board params pull|push|table`: fly's saved parameters as a text file, through the
// same path as `board eeprom get|put` (read through the running firmware's `eeprom dump`,
// written through the stock bootloader, verified with the firmware's `eeprom crc`), and the
// docs' parameter table. The table comes out of fly.hex (board/params.hpp).
#include <fstream>
#include <memory>
#include <sstream>

#include <fmt/format.h>

#include "board/cli_support.hpp"
#include "board/params.hpp"
#include "board/transfer.hpp"

namespace board {
namespace {

std::string readText(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ParamError(fmt::format("{}: cannot read the {}; check the path", path, what));
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  if (!out || !(out << text)) throw ParamError(fmt::format("{}: cannot write it; check the directory", path));
}

// The board's record must be this table's to be read back as a file.
void requireReadable(const BoardParamState& s) {
  using How = BoardParamState::How;
  if (s.how == How::kOtherLayout || s.how == How::kCannotBeRight)
    throw ParamError(fmt::format("the board's saved parameters: {}; pass the fly.hex that saved them with "
                                 "--image, or push a file over them",
                                 s.why));
}

void pull(const std::string& port, const std::string& file, const std::string& image) {
  requirePort(port);
  const ParamTableCopy t = readParamTable(image);
  TransferOptions to;
  to.progress = info;
  const EepromGetResult got = getEeprom(port, to);
  const BoardParamState s = paramsInImage(t, got.bytes);
  requireReadable(s);
  const bool saved = s.how == BoardParamState::How::kLoaded;
  std::vector<std::string> head = {
      saved ? fmt::format("fly parameters from {} ({}), read through {}", port, s.why, imageName(got.image))
            : fmt::format("fly parameters from {}: {}, so these are fly's defaults", port, s.why),
      "table: " + t.origin,
      "NAME VALUE per line, '#' starts a comment; thrustcal board params push --port PORT FILE puts them back"};
  writeText(file, formatParamFile(t, s.values, head));
  std::printf("wrote %zu parameters to %s (%s)\n", t.rows.size(), file.c_str(),
              saved ? s.why.c_str() : "none saved: the defaults");
}

// long: read the file, the board, merge, store as fly would, write the one copy, verify
void push(const std::string& port, const std::string& file, const std::string& image, double timeout_s) {
  requirePort(port);
  const ParamTableCopy t = readParamTable(image);
  const std::string text = readText(file, "parameter file");
  parseParamFile(t, text, file, t.defaults());  // every line checked before the board is touched
  TransferOptions to;
  to.avrdude_timeout_s = timeout_s;
  to.progress = info;
  const EepromGetResult got = getEeprom(port, to);
  const BoardParamState s = paramsInImage(t, got.bytes);
  if (s.how != BoardParamState::How::kLoaded)
    info(fmt::format("the board's parameters: {}; names {} leaves out get fly's defaults", s.why, file));
  const ParamFile f = parseParamFile(t, text, file, s.values);
  std::vector<uint8_t> next = got.bytes;
  const tc::ParamsWrite w = storeParamsInImage(t, f.values, next);
  if (w.status == tc::ParamsWriteStatus::kUnchanged) {
    std::printf("the board on %s holds these parameters already (%s); nothing written\n", port.c_str(),
                s.why.c_str());
    return;
  }
  if (w.status == tc::ParamsWriteStatus::kNoRoom)
    throw ParamError("no room on the board: all four slots hold thesis (v1) records, which fill the EEPROM; "
                     "store a motor as model v2 or erase a slot (gather_store) first; nothing written");
  if (w.status != tc::ParamsWriteStatus::kWritten)
    throw ParamError("the record did not store in the image (a bug); nothing written");
  const std::size_t first = tc::slotAddress(w.host) + tc::kParamsOffsetA + w.copy * tc::kParamsCopyBytes;
  const EepromRangeResult r = putEepromRange(port, next, first, tc::kParamsCopyBytes, "params push", to);
  std::printf("pushed %s to %s: %zu of %zu parameters from the file, the rest kept; motor %u's slot, copy %c, "
              "sequence %u (bytes %zu..%zu, %.1f s); verified through %s: %s\n",
              file.c_str(), port.c_str(), f.givenCount(), t.rows.size(), w.host, w.copy == 0 ? 'A' : 'B',
              w.sequence, first, first + tc::kParamsCopyBytes - 1, r.wall_s, imageName(r.image),
              r.crcs.text().c_str());
  for (const auto& line : r.boot)
    if (line.rfind("params: ", 0) == 0) std::printf("fly says: %s\n", line.c_str());
}

void table(const std::string& image, const std::string& docs, bool check) {
  const ParamTableCopy t = readParamTable(image);
  const std::string md = paramDocsTable(t);
  if (docs.empty()) {
    std::fputs(md.c_str(), stdout);
    return;
  }
  const std::string before = readText(docs, "docs page");
  const std::string after = withParamDocsTable(before, md, docs);
  if (check) {
    if (after != before)
      throw ParamError(fmt::format("{}: its parameter table differs from {}; run thrustcal board params table "
                                   "--docs {}",
                                   docs, t.origin, docs));
    std::printf("%s: the parameter table matches %s\n", docs.c_str(), t.origin.c_str());
    return;
  }
  if (after != before) writeText(docs, after);
  std::printf("%s: parameter table %s (%s)\n", docs.c_str(), after != before ? "written" : "unchanged",
              t.origin.c_str());
}

}  // namespace

// long: three subcommands, each its options and one call
void addParams(CLI::App& board) {
  auto* p = board.add_subcommand(
      "params",
      "fly's saved parameters (its `param` commands) as a text file: NAME VALUE per line, '#'\n"
      "comments. The names, ranges and record layout come from fly's image (--image fly.hex).");
  p->require_subcommand(1);
  auto image = std::make_shared<std::string>(defaultFlyHex());
  {
    auto* cmd = p->add_subcommand("pull", "Read the board's saved parameters (through `eeprom dump`) into FILE.");
    auto port = std::make_shared<std::string>();
    auto file = std::make_shared<std::string>();
    cmd->add_option("--port,-P", *port, "serial port (any image that answers `eeprom dump`)")->required();
    cmd->add_option("FILE", *file, "parameter file to write")->required();
    cmd->add_option("--image", *image, "fly's Intel HEX image (its parameter table)")->capture_default_str();
    cmd->callback([=] { guarded([&] { pull(*port, *file, *image); }); });
  }
  {
    auto* cmd = p->add_subcommand(
        "push",
        "Store FILE's parameters on the board as fly's `param save` would: checked line by line first\n"
        "(nothing is written on a bad file), names it leaves out keep the board's values, only the\n"
        "record's copy that is not the newest is written through the bootloader, then verified.");
    auto port = std::make_shared<std::string>();
    auto file = std::make_shared<std::string>();
    auto timeout = std::make_shared<double>(180.0);
    cmd->add_option("--port,-P", *port, "serial port")->required();
    cmd->add_option("FILE", *file, "parameter file (thrustcal board params pull, or fly's `param list`)")
        ->required();
    cmd->add_option("--image", *image, "fly's Intel HEX image (its parameter table)")->capture_default_str();
    cmd->add_option("--timeout", *timeout, "give avrdude this many seconds")->capture_default_str();
    cmd->callback([=] { guarded([&] { push(*port, *file, *image, *timeout); }); });
  }
  {
    auto* cmd = p->add_subcommand(
        "table", "fly's parameter table as Markdown: on stdout, or between the markers of --docs FILE.");
    auto docs = std::make_shared<std::string>();
    auto check = std::make_shared<bool>(false);
    cmd->add_option("--image", *image, "fly's Intel HEX image (its parameter table)")->capture_default_str();
    cmd->add_option("--docs", *docs, "write the table into this page (docs/fly.md) between its markers");
    cmd->add_flag("--check", *check, "with --docs: write nothing, exit 1 when the page's table differs");
    cmd->callback([=] { guarded([&] { table(*image, *docs, *check); }); });
  }
}

}  // namespace board
