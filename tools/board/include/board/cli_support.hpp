// What the `thrustcal board ...` commands share (cli.cpp, params_cli.cpp): progress lines on
// stderr and one way to turn an error into a message and an exit code.
#pragma once
#include <CLI/CLI.hpp>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "board/console_client.hpp"

namespace board {

inline void info(const std::string& line) {
  std::fprintf(stderr, "board: %s\n", line.c_str());
  std::fflush(stderr);
}

// Runs `body`; any error becomes a message and exit code 1 (130 after Ctrl-C).
template <class F>
void guarded(F&& body) {
  try {
    body();
  } catch (const Interrupted& e) {
    std::fprintf(stderr, "\nthrustcal board: interrupted: %s\n", e.what());
    std::exit(130);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "\nthrustcal board: error: %s\n", e.what());
    std::exit(1);
  }
}

// `thrustcal board params pull|push|table` (params_cli.cpp).
void addParams(CLI::App& board);

}  // namespace board
