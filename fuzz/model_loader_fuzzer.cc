// libFuzzer entry point for the whole front end of `multibond run` (scripts/fuzz runs it); what
// it does is fuzz/run_front_end.h.
//
// The input bytes are a model file's text. A ModelError is the expected answer to a bad model;
// anything else escaping (std::logic_error from MB_ASSERT, YAML::Exception, std::bad_alloc,
// out_of_range ...) or any sanitizer report is a bug: it is not caught, so libFuzzer reports it.
// Reproducers go to tests/models/fuzz/ with a regression test in tests/io/fuzz_regression_test.cc.

#include <cstddef>
#include <cstdint>
#include <string>

#include "run_front_end.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    multibond::fuzz::RunFrontEnd(std::string(reinterpret_cast<const char*>(data), size), "<fuzz>");
  } catch (const multibond::ModelError&) {
    // A diagnosed bad model: the expected outcome for most inputs.
  }
  return 0;
}
