#include "board/avrdude.hpp"

#include "hal/board.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <sstream>

#include <fmt/format.h>

extern char** environ;

namespace board {
namespace {

bool isExecutable(const std::string& path) { return ::access(path.c_str(), X_OK) == 0; }

}  // namespace

std::string findAvrdude() {
  if (const char* env = std::getenv("THRUSTCAL_AVRDUDE"); env && *env) {
    if (!isExecutable(env))
      throw AvrdudeError(fmt::format("THRUSTCAL_AVRDUDE={} is not an executable file", env));
    return env;
  }
  if (const char* path = std::getenv("PATH")) {
    std::stringstream dirs(path);
    for (std::string dir; std::getline(dirs, dir, ':');) {
      const std::string candidate = (dir.empty() ? std::string(".") : dir) + "/avrdude";
      if (isExecutable(candidate)) return candidate;
    }
  }
  throw AvrdudeError(
      "avrdude is not installed (it talks to the Mega2560's bootloader); install it with "
      "`sudo apt-get install avrdude` (tools/test.sh and tools/demo.sh do), or point "
      "THRUSTCAL_AVRDUDE at it");
}

std::vector<std::string> avrdudeArgs(const std::string& port) {
  return {"-p", "m2560", "-c", "wiring", "-P", port, "-b", std::to_string(hal::kBootloaderBaud), "-D"};
}

AvrdudeRun runAvrdude(const std::vector<std::string>& args, double timeout_s,
                      const std::function<void(const std::string&)>& on_output) {
  AvrdudeRun run;
  const std::string exe = findAvrdude();
  int pipe_fd[2];
  if (::pipe(pipe_fd) != 0) throw AvrdudeError(fmt::format("pipe: {}", std::strerror(errno)));
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addclose(&actions, pipe_fd[0]);
  posix_spawn_file_actions_adddup2(&actions, pipe_fd[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, pipe_fd[1], STDERR_FILENO);
  posix_spawn_file_actions_addclose(&actions, pipe_fd[1]);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);  // Ctrl-C reaches us, not avrdude
  posix_spawnattr_setpgroup(&attr, 0);
  std::vector<char*> argv;
  argv.push_back(const_cast<char*>(exe.c_str()));
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  const auto t0 = std::chrono::steady_clock::now();
  const int err = ::posix_spawn(&pid, exe.c_str(), &actions, &attr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  ::close(pipe_fd[1]);
  if (err != 0) {
    ::close(pipe_fd[0]);
    throw AvrdudeError(fmt::format("cannot start {}: {}", exe, std::strerror(err)));
  }
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  bool killed = false;
  char buf[4096];
  for (;;) {
    pollfd p{pipe_fd[0], POLLIN, 0};
    const int r = ::poll(&p, 1, 100);
    if (r > 0) {
      const ssize_t n = ::read(pipe_fd[0], buf, sizeof buf);
      if (n <= 0) break;  // avrdude closed its output: it is ending
      std::string chunk(buf, static_cast<std::size_t>(n));
      run.output += chunk;
      if (on_output) on_output(chunk);
    }
    if (!killed && elapsed() > timeout_s) {
      ::kill(pid, SIGTERM);
      killed = true;
      run.timed_out = true;
    } else if (killed && elapsed() > timeout_s + 2.0) {
      ::kill(pid, SIGKILL);
    }
  }
  ::close(pipe_fd[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  run.wall_s = elapsed();
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return run;
}

std::string lastLines(const std::string& output, std::size_t n) {
  std::vector<std::string> lines;
  std::string cur;
  for (char c : output) {
    if (c == '\n' || c == '\r') {
      if (!cur.empty()) lines.push_back(cur);
      cur.clear();
    } else {
      cur.push_back(c);
    }
  }
  if (!cur.empty()) lines.push_back(cur);
  std::string out;
  for (std::size_t i = lines.size() > n ? lines.size() - n : 0; i < lines.size(); ++i)
    out += "  | " + lines[i] + "\n";
  return out;
}

}  // namespace board
