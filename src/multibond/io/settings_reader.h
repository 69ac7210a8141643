#pragma once
/// \file
/// Reading the model-wide settings: the default domain, 'constraints' and 'algebraic_loops' (how
/// the model is compiled) and the 'simulation' section (how it is run, unless the command line says).

#include "multibond/io/model_loader.h"
#include "multibond/io/yaml_values.h"

namespace multibond {

class SettingsReader : public ValueReader {
 public:
  using ValueReader::ValueReader;

  /// 'domain', 'constraints' and 'algebraic_loops' of the model's top level.
  void ReadCompileSettings(const YAML::Node& root, CompileOptions& options);
  /// The 'simulation' section; `mechanism`: the model has bodies (joint coordinates need them).
  void ReadSimulation(const YAML::Node& n, SimulationDefaults& s, bool mechanism);
};

}  // namespace multibond
