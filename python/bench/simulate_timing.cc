// The C++ side of bench/run_overhead.py: the mean wall time of Model::Simulate (the public C++
// API) on a model file, after a warm-up, with the run options given. Prints seconds per run.
//   multibond_py_bench_simulate MODEL T_END DT REPEATS

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <multibond/multibond.h>

int main(int argc, char** argv) {
  if (argc != 5) return std::fprintf(stderr, "usage: %s MODEL T_END DT REPEATS\n", argv[0]), 64;
  multibond::Model model = multibond::Model::FromFile(argv[1]);
  multibond::BuildOptions build;
  build.jit = "off";
  model.Build(build);
  multibond::SimulationOptions o;
  o.t_end = std::atof(argv[2]);
  o.dt = std::atof(argv[3]);
  const int repeats = std::atoi(argv[4]);
  double sink = 0.0;
  for (int k = 0; k < 10; ++k) sink += model.Simulate(o).rows();
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < repeats; ++k) sink += model.Simulate(o).rows();
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("%.9g\n", s / repeats);
  return sink > 0 ? 0 : 1;
}
