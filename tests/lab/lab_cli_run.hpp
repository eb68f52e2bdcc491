// Runs `thrustcal lab ...` in-process as the command line would (CLI11 parse with the lab's
// commands registered) and captures what it prints: the lab's CLI tests share this one runner.
#pragma once
#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "lab/cli.hpp"

namespace labtest {

struct CliRun {
  int rc = 0;           // the exit code CLI11 gives the error, 0 when the command ran
  std::string out, err;  // stdout, stderr (with the parse error's text)
};

// `args` without the program name, e.g. {"lab", "diagnose", "x.csv"}.
inline CliRun runLabCli(std::vector<std::string> args) {
  CLI::App app{"thrustcal"};
  app.require_subcommand(1);
  lab::registerCommands(app);
  args.insert(args.begin(), "thrustcal");
  std::vector<const char*> argv;
  for (const auto& a : args) argv.push_back(a.c_str());
  CliRun r;
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  try {
    app.parse(static_cast<int>(argv.size()), argv.data());
  } catch (const CLI::Error& e) {
    r.rc = e.get_exit_code();
    r.err = e.what();
  }
  r.out = testing::internal::GetCapturedStdout();
  r.err += testing::internal::GetCapturedStderr();
  return r;
}

}  // namespace labtest
