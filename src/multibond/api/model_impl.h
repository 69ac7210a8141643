#pragma once
/// \file
/// What a public Model holds (model.cc, linear.cc): the loaded model, the limits and build options
/// it was given, and the compiled model once built.

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "multibond/api/lookup.h"
#include "multibond/compile/compiled_model.h"
#include "multibond/compile/generated_rhs.h"
#include "multibond/io/model_loader.h"
#include "multibond/multibond.h"

namespace multibond {

struct Model::Impl {
  LoadedModel lm;
  InputLimits limits;
  BuildOptions build;
  std::shared_ptr<const CompiledModel> compiled;
  std::shared_ptr<const GeneratedRhs> code;  ///< its generated code (jit auto or on), else null

  Element& FindElement(std::string_view name) {
    const int i = lm.graph.Find(std::string(name));
    if (i < 0) {
      std::vector<std::string> names;
      for (const Element& e : lm.graph.elements()) names.push_back(e.name);
      ThrowUnknownName("element", name, names);
    }
    compiled.reset();  // every change unbuilds
    code.reset();
    return lm.graph.element(i);
  }
  const CompiledModel& Built() const {
    if (!compiled) throw std::logic_error("the model is not built: call Build() first");
    return *compiled;
  }
  const std::string& Engine() const {
    static const std::string kInterpreter = "interpreter";
    (void)Built();
    return code ? code->engine() : kInterpreter;
  }
};

}  // namespace multibond
