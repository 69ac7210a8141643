// Embedding multibond: a mass-spring-damper given as a string, simulated in one run and then step
// by step, its final position checked against the closed form. Exit status 0 when both agree
// with it to 1e-6 m, 1 otherwise. (docs/api.md explains each call.)

#include <cmath>
#include <cstdio>
#include <exception>

#include <multibond/multibond.h>

namespace {

// m x'' + c x' + k x = F with a force step at t = 0, from rest.
constexpr double kMass = 1.0, kStiffness = 100.0, kDamping = 2.0, kForce = 1.0;

const char* const kModel = R"(
model: mass_spring_damper
domain: translation
elements:
  force:  {type: Se, effort: 1.0}
  mass:   {type: I, inertia: 1.0}
  spring: {type: C, stiffness: 100.0}
  damper: {type: R, resistance: 2.0}
  j:      {type: "1"}
bonds:
  - force -> j
  - j -> mass
  - j -> spring
  - j -> damper
outputs:
  - {name: velocity, variable: j.f}
)";

/// The closed-form displacement of the underdamped oscillator.
double Position(double t) {
  const double w0 = std::sqrt(kStiffness / kMass), zeta = kDamping / (2 * std::sqrt(kStiffness * kMass));
  const double wd = w0 * std::sqrt(1 - zeta * zeta);
  return kForce / kStiffness * (1 - std::exp(-zeta * w0 * t) * (std::cos(wd * t) + zeta * w0 / wd * std::sin(wd * t)));
}

}  // namespace

int main() {
  try {
    multibond::Model model = multibond::Model::FromString(kModel, "mass_spring_damper");
    model.SetParameter("spring", kStiffness);  // a parameter set from the program (here: the file's value)
    multibond::BuildOptions build;
    build.jit = "off";  // the plan interpreter: no C++ compiler needed at run time
    model.Build(build);

    // One run, every output row kept.
    multibond::SimulationOptions options;
    options.t_end = 2.0;
    options.dt = 0.01;
    options.solver = "bdf";
    options.rtol = 1e-10;
    options.atol = 1e-12;
    const multibond::Results results = model.Simulate(options);
    if (!results.ok()) {
      std::fprintf(stderr, "run failed: %s\n", results.summary().message.c_str());
      return 1;
    }
    const double run_x = results.column("spring.q").back();
    std::printf("run:   %zu rows, x(2 s) = %.9f m, closed form %.9f m, %ld steps\n", results.rows(), run_x, Position(2.0),
                results.summary().steps);

    // The same, step by step: 0.1 s at a time, reading the state between steps.
    multibond::Simulation sim = model.Start(options);
    for (int k = 1; k <= 20; ++k) {
      sim.AdvanceTo(0.1 * k);
      if (k % 5 == 0) std::printf("step:  t = %.1f s  x = %+.6f m  v = %+.6f m/s\n", sim.time(), sim.Value("spring.q"), sim.Value("velocity"));
    }
    const double step_x = sim.Value("spring.q");

    const double error = std::max(std::abs(run_x - Position(2.0)), std::abs(step_x - Position(2.0)));
    std::printf("largest error against the closed form: %.3g m\n", error);
    return error < 1e-6 ? 0 : 1;
  } catch (const multibond::ModelError& e) {
    for (const multibond::Diagnostic& d : e.diagnostics()) std::fprintf(stderr, "%s\n", d.ToString().c_str());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
