#pragma once
// Test helpers: the programs that read results.mat and results.h5 as users do. Debian's
// /usr/bin/python3 with SciPy and h5py (found by CMake: MULTIBOND_SYSTEM_PYTHON, "" when absent)
// and Octave (MULTIBOND_OCTAVE). A test that needs one that is missing is skipped, saying why.

#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "support/cli_runner.h"

namespace multibond::testing {

/// Why `program` with `modules` cannot run here ("" when it can): absent, or a module missing.
inline std::string PythonMissing(const std::vector<std::string>& modules) {
  const std::string python = MULTIBOND_SYSTEM_PYTHON;
  if (python.empty() || access(python.c_str(), X_OK) != 0) return "no system python3 (/usr/bin/python3) was found at configure time";
  std::string imports;
  for (const std::string& m : modules) imports += "import " + m + "\n";
  const CliResult r = RunProgram({python, "-c", imports}, 60);
  return r.code == 0 ? "" : python + " cannot import what the test needs: " + r.out;
}

inline std::string OctaveMissing() {
  const std::string octave = MULTIBOND_OCTAVE;
  if (octave.empty() || access(octave.c_str(), X_OK) != 0) return "no octave was found at configure time";
  return "";
}

/// Runs `script` with the system python3; stdout and stderr together.
inline CliResult RunPython(const std::string& script, const std::vector<std::string>& args = {}) {
  std::vector<std::string> argv = {MULTIBOND_SYSTEM_PYTHON, "-c", script};
  argv.insert(argv.end(), args.begin(), args.end());
  return RunProgram(argv, 120);
}

/// The 64 bits of `x` in hex, as the scripts print the values they read (so that NaN, infinities,
/// -0 and subnormals compare to the last bit).
inline std::string Bits(double x) {
  std::uint64_t u;
  std::memcpy(&u, &x, sizeof u);
  return fmt::format("{:016x}", u);
}

/// The Bits of every value of a column.
template <class Values>
std::vector<std::string> BitsOf(const Values& values) {
  std::vector<std::string> bits;
  for (const double x : values) bits.push_back(Bits(x));
  return bits;
}

/// Runs `code` in Octave (no GUI, no startup files).
inline CliResult RunOctave(const std::string& code) {
  return RunProgram({MULTIBOND_OCTAVE, "--no-gui", "--norc", "--quiet", "--no-window-system", "--eval", code}, 120);
}

}  // namespace multibond::testing
