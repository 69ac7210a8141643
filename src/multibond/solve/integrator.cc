#include "multibond/solve/integrator.h"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/solve/arkode_integrator.h"
#include "multibond/solve/cvode_integrator.h"

namespace multibond {
namespace {

constexpr const char* kValidNames = "bdf, adams, dopri5 (or dormand-prince), bs3 (or bogacki-shampine), srk3 (or stabilized-rk3), rk4";

/// For a model without states (purely algebraic): time just advances, nothing to integrate.
/// SUNDIALS cannot be given zero-length vectors.
class StatelessIntegrator final : public Integrator {
 public:
  explicit StatelessIntegrator(const IntegratorOptions& options) : options_(options) {}
  void Reset(double t0, const double* /*x0*/) override { time_ = t0; }
  void AdvanceTo(double tout, double* /*x*/) override {
    MB_ASSERT(tout >= time_, fmt::format("AdvanceTo({}) is before the current time {}", tout, time_));
    time_ = tout;
  }
  double AdvanceUntil(double tout, double, double* x, int*) override {  // no state: no event function either
    AdvanceTo(tout, x);
    return tout;
  }
  double time() const override { return time_; }
  IntegratorStats stats() const override { return {}; }
  const IntegratorOptions& options() const override { return options_; }

 private:
  IntegratorOptions options_;
  double time_ = 0.0;
};

void Require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument(message);
}

void Validate(const IntegratorOptions& o, int num_states) {
  Require(o.method != Method::kRk4 || o.fixed_step > 0, "rk4 needs a fixed step (--step)");
  Require(std::isfinite(o.fixed_step) && o.fixed_step >= 0,
          fmt::format("the fixed step must be positive (got {})", o.fixed_step));
  CheckRelativeTolerance(o.rtol);
  Require(std::isfinite(o.atol) && o.atol >= 0,
          fmt::format("atol must be a finite number >= 0 (got {})", o.atol));
  if (!o.atol_per_state.empty()) {
    Require(static_cast<int>(o.atol_per_state.size()) == num_states,
            fmt::format("{} absolute tolerances given for {} states", o.atol_per_state.size(),
                        num_states));
    for (double a : o.atol_per_state)
      Require(std::isfinite(a) && a >= 0,
              fmt::format("absolute tolerances must be finite numbers >= 0 (got {})", a));
  }
  Require(std::isfinite(o.max_step) && o.max_step >= 0,
          fmt::format("max_step must be >= 0, 0 meaning no limit (got {})", o.max_step));
  Require(std::isfinite(o.initial_step) && o.initial_step >= 0,
          fmt::format("initial_step must be >= 0, 0 meaning automatic (got {})", o.initial_step));
  Require(o.max_steps_per_output > 0,
          fmt::format("max_steps_per_output must be positive (got {})", o.max_steps_per_output));
}

}  // namespace

JacobianKind ParseJacobianKind(const std::string& name) {
  if (name == "auto") return JacobianKind::kAuto;
  if (name == "dense") return JacobianKind::kDense;
  if (name == "sparse") return JacobianKind::kSparse;
  throw std::invalid_argument(fmt::format("unknown Jacobian kind '{}' (valid: auto, dense, sparse)", name));
}

const char* JacobianKindName(JacobianKind k) {
  switch (k) {
    case JacobianKind::kAuto: return "auto";
    case JacobianKind::kDense: return "dense";
    case JacobianKind::kSparse: return "sparse";
  }
  return "?";
}

Method ParseMethod(const std::string& name) {
  if (name == "bdf") return Method::kBdf;
  if (name == "adams") return Method::kAdams;
  if (name == "dopri5" || name == "dormand-prince") return Method::kDormandPrince;
  if (name == "bs3" || name == "bogacki-shampine") return Method::kBogackiShampine;
  if (name == "srk3" || name == "stabilized-rk3") return Method::kStabilizedRk3;
  if (name == "rk4") return Method::kRk4;
  throw std::invalid_argument(
      fmt::format("unknown integration method '{}'; valid methods: {}", name, kValidNames));
}

const char* MethodName(Method m) {
  switch (m) {
    case Method::kBdf:
      return "bdf";
    case Method::kAdams:
      return "adams";
    case Method::kDormandPrince:
      return "dopri5";
    case Method::kRk4:
      return "rk4";
    case Method::kBogackiShampine:
      return "bs3";
    case Method::kStabilizedRk3:
      return "srk3";
  }
  return "unknown";
}

void CheckRelativeTolerance(double rtol) {
  Require(std::isfinite(rtol) && rtol >= 0, fmt::format("rtol must be a finite number >= 0 (got {})", rtol));
  Require(rtol < 1, fmt::format("rtol is a relative tolerance and must be below 1 (got {:g}); typical values are 1e-6 to 1e-10", rtol));
}

void CheckIntegratorOptions(int n, const JacobianPattern* pattern, const IntegratorOptions& options) {
  MB_ASSERT(n >= 0, "negative number of states");
  Validate(options, n);
  if (n == 0) return;
  const bool cvode = UsesNewtonMatrix(options.method);
  Require(!(cvode && options.fixed_step > 0),
          fmt::format("a fixed step (--step) is for {}; {} chooses its own steps (bound them with --max-step)",
                      kFixedStepMethodNames, MethodName(options.method)));
  Require(options.jacobian != JacobianKind::kSparse || pattern != nullptr || !cvode,
          "a sparse Jacobian needs the model's Jacobian pattern, and this model has none (a model with ideal "
          "constraints, whose multipliers couple the states they reach, or with solved algebraic loops, whose "
          "unknowns couple what their loops read, and no energy integrals to leave out); use the dense or automatic "
          "Jacobian");
}

std::unique_ptr<Integrator> MakeIntegrator(OdeSystem& system, const IntegratorOptions& options) {
  CheckIntegratorOptions(system.num_states(), UsesNewtonMatrix(options.method) ? system.jacobian_pattern() : nullptr, options);
  if (system.num_states() == 0) return std::make_unique<StatelessIntegrator>(options);
  switch (options.method) {
    case Method::kBdf:
    case Method::kAdams:
      return MakeCvodeIntegrator(system, options);
    case Method::kDormandPrince:
    case Method::kBogackiShampine:
    case Method::kStabilizedRk3:
    case Method::kRk4:
      return MakeArkodeIntegrator(system, options);
  }
  MB_ASSERT(false, "unhandled integration method");
}

}  // namespace multibond
