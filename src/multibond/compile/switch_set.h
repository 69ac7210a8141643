#pragma once
/// \file
/// What makes a model's motion piecewise, a part of the compiled model (docs/events.md): the
/// switching elements (contacts, frictions, clutches, stops: compile/switching.h), the kinks and
/// switches of formulas (compile/kinks.h), and which of those kinks may slide (a sign of the
/// state, compile/sliding.cc). Made by BuildSwitches and the formula passes; the event functions,
/// event handling and the evaluation read it.

#include <vector>

#include "multibond/compile/kinks.h"
#include "multibond/compile/switching.h"

namespace multibond {

struct SwitchSet {
  SwitchTable switches;
  KinkTable kinks;
  std::vector<int> slides;  ///< the kinks that may slide (a sign of the state), by index in kinks
};

}  // namespace multibond
