// libFuzzer entry point for the model loader and the compiler (scripts/fuzz runs it).
//
// The input bytes are a model file's text. A ModelError is the expected answer to a bad model;
// anything else escaping (std::logic_error from MB_ASSERT, YAML::Exception, std::bad_alloc,
// out_of_range ...) or any sanitizer report is a bug: it is not caught, so libFuzzer reports it.
// Reproducers go to tests/models/fuzz/ with a regression test in tests/io/fuzz_regression_test.cc.

#include <cstddef>
#include <cstdint>
#include <string>

#include <Eigen/Dense>

#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace mb = multibond;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const mb::LoadedModel lm = mb::LoadModelString(text, "<fuzz>");
    const auto model = mb::CompiledModel::Compile(lm.graph, lm.compile);
    (void)mb::MakeColumns(*model, false);  // output layout: `multibond run` does this before simulating
    if (model->num_states() < 2000) {
      mb::Workspace ws = model->MakeWorkspace();
      const Eigen::VectorXd x = model->MakeInitialState();
      Eigen::VectorXd xdot(x.size());
      model->CalcDerivatives(0.0, x.data(), xdot.data(), ws);
    }
  } catch (const mb::ModelError&) {
    // A diagnosed bad model: the expected outcome for most inputs.
  }
  return 0;
}
