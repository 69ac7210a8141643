#pragma once
/// \file
/// The catalogue of diagnostic codes: every code a diagnostic of multibond can carry, what it
/// means and how `multibond` exits for it. The loader names its codes by these constants; the table
/// of codes in docs/model-format.md is checked against this one (tests/core/diagnostic_codes_test.cc),
/// as are the codes the bad-model corpus and the documentation's examples expect.
///
/// Every layer names its codes by these constants (core is below them all); a test fails on a
/// code spelt as a string literal anywhere else in the sources.

#include <string_view>

namespace multibond::codes {

/// How the command line ends when a diagnostic of the code is reported (README, "Exit codes").
enum class Outcome {
  kWarning = 0,     ///< the model runs; the diagnostic is shown
  kModelError = 1,  ///< the model is refused
  kFileError = 74,  ///< the model file cannot be read (I/O)
  kUsage = 64,      ///< bad input of a command other than the model (a sweep's study)
};

// X(constant, code, outcome, meaning): one row per code, in the order of the documentation's table.
#define MULTIBOND_DIAGNOSTIC_CODES(X)                                                                                          \
  X(kYamlSyntax, "yaml.syntax", kModelError, "a YAML syntax error (an unclosed bracket, a line indented deeper than its block)") \
  X(kYamlStructure, "yaml.structure", kModelError, "a YAML node of a shape the format does not expect there")               \
  X(kYamlDuplicateKey, "yaml.duplicate_key", kModelError, "a key given twice in one mapping")                                 \
  X(kYamlSelfAlias, "yaml.self_alias", kModelError, "an alias inside the node of its own anchor")                             \
  X(kKeyUnknown, "key.unknown", kModelError, "a key the format does not know there (the hint names the nearest known one)") \
  X(kKeyMissing, "key.missing", kModelError, "a key or section that an element, body, joint, state, output or the model needs and does not have") \
  X(kKeyConflict, "key.conflict", kModelError, "keys that exclude each other given together, or a key that goes with another one that is not given") \
  X(kValueUnknown, "value.unknown", kModelError, "a word the format does not know there: a domain, time function, state kind, axis, frame, shape, drive type, solver or setting") \
  X(kTextEncoding, "text.encoding", kModelError, "a byte that is not UTF-8, or a control character, in the file")            \
  X(kNameInvalid, "name.invalid", kModelError, "a name outside the identifier grammar, or a reserved one")                   \
  X(kNameDuplicate, "name.duplicate", kModelError, "a bond named twice, or named like an element; a parameter, signal or state named like another")                           \
  X(kUnitInvalid, "unit.invalid", kModelError, "a unit outside the unit grammar")                                            \
  X(kSubmodelRecursive, "submodel.recursive", kModelError, "a submodel that contains itself, directly or through others")     \
  X(kBondSyntax, "bond.syntax", kModelError, "a bond not written 'from -> to', [from, to] or {from: ..., to: ...}, or with an end missing") \
  X(kBondUnknownEnd, "bond.unknown_end", kModelError, "a bond end, or a submodel's port, that names no element (or no port of the instance)") \
  X(kBondSelf, "bond.self", kModelError, "a bond from an element to itself") \
  X(kParamUnknown, "param.unknown", kModelError,                                                                               \
    "a name in a formula that is no parameter (nor, where a formula may change in time, a variable, signal or state)")          \
  X(kParamCycle, "param.cycle", kModelError, "parameters whose formulas depend on each other in a cycle")                      \
  X(kExprSyntax, "expr.syntax", kModelError, "a formula outside the grammar of expressions (an operator missing, a bracket left open)") \
  X(kExprUnknownFunction, "expr.unknown_function", kModelError, "a formula that calls a function the grammar does not have")  \
  X(kExprArity, "expr.arity", kModelError, "a function called with the wrong number of arguments")                           \
  X(kExprNotConstant, "expr.not_constant", kModelError,                                                                        \
    "time or a model variable in a formula where a constant is needed (a parameter, a number of an element)")                 \
  X(kExprUnits, "expr.units", kModelError,                                                                                     \
    "units that do not fit where they are declared: a sum of a length and a time, the sine of a length, a parameter whose formula gives another unit than its own") \
  X(kExprAngularFrequencyInHz, "expr.angular_frequency_in_hz", kModelError,                                                     \
    "a parameter declared in Hz whose formula takes a square root and no 2 pi (sqrt(k/m) is rad/s): a 2 pi error that units cannot see") \
  X(kLimitFileSize, "limit.file-size", kModelError, "the limit file-size exceeded")                                          \
  X(kLimitYamlNodes, "limit.yaml-nodes", kModelError, "the limit yaml-nodes exceeded")                                       \
  X(kLimitDepth, "limit.depth", kModelError, "the limit depth exceeded")                                                     \
  X(kLimitInstances, "limit.instances", kModelError, "the limit instances exceeded")                                         \
  X(kLimitElements, "limit.elements", kModelError, "the limit elements exceeded")                                            \
  X(kLimitBonds, "limit.bonds", kModelError, "the limit bonds exceeded")                                                     \
  X(kIoNotRegular, "io.not_regular", kFileError, "the model is not a regular file (a directory, device, FIFO or socket)")    \
  X(kIoUnreadable, "io.unreadable", kFileError, "the model file cannot be opened or read")                                   \
  X(kStructureDangling, "structure.dangling", kModelError, "an element without bonds")                                       \
  X(kStructureDimension, "structure.dimension", kModelError, "bond dimensions that do not fit")                              \
  X(kStructurePorts, "structure.ports", kModelError, "an element with a number of bonds its kind does not take, or a two-port whose bonds do not run one in and one out") \
  X(kDomainConflict, "domain.conflict", kModelError, "bonds of different domains that meet at a junction or an element") \
  X(kStateOf, "state.of", kModelError, "a state whose 'of' names no element, a 0-junction (no single flow), or a flow of the wrong size") \
  X(kElementType, "element.type", kModelError, "an element type that does not exist (neither a kind of element nor a submodel)") \
  X(kParamRange, "param.range", kModelError,                                                                                   \
    "a parameter out of range: non-positive inertia or stiffness, negative resistance, wrong number of source components or " \
    "initial values, non-finite numbers, a rotation or lever that is no state")                                              \
  X(kParamShape, "param.shape", kModelError, "a value of the wrong size: a ragged matrix, a vector or table row of the wrong length, a table of one row, matrices that do not fit together, a constraint whose compliances fit none of its components")   \
  X(kParamSingular, "param.singular", kModelError, "a resistor in conductance causality with a singular resistance")         \
  X(kExprTooLarge, "expr.too_large", kModelError, "a formula that needs more than 256 intermediate values at once")       \
  X(kExprUnknownVariable, "expr.unknown_variable", kModelError,                                                               \
    "a name in a formula that is no parameter, signal, state or variable of the model (found when it is compiled)")           \
  X(kExprVectorLaw, "expr.vector_law", kModelError, "a law given by a formula on a bond of more than one component")          \
  X(kExprUnsupported, "expr.unsupported", kModelError,                                                                         \
    "a formula where formulas are not supported yet: with ideal constraints, or in an algebraic loop solved by tearing")      \
  X(kLawEnergy, "law.energy", kModelError,                                                                                     \
    "a stored energy that does not depend on its element's own state, or a storage law whose modulation's work cannot be "     \
    "booked (a read without a rate in the plan, such as an effort or a flow; a modulated law without a closed-form energy)")   \
  X(kCausalityConflict, "causality.conflict", kModelError,                                                                     \
    "two elements impose the same effort or flow (two Se on a 0-junction, two Sf on a 1-junction, both ports of a two-port " \
    "given the same variable)")                                                                                                \
  X(kCausalityUndetermined, "causality.undetermined", kModelError, "no bond of a junction determines its common variable")   \
  X(kCausalityDerivative, "causality.derivative", kModelError, "an I or C in derivative causality")                          \
  X(kCausalityAlgebraicLoop, "causality.algebraic_loop", kModelError,                                                          \
    "variables that depend on themselves through resistors and junctions")                                                     \
  X(kCausalityArbitrary, "causality.arbitrary", kWarning, "a bond whose causality nothing fixes")                           \
  X(kConstraintUnsupported, "constraint.unsupported", kModelError,                                                             \
    "an ideal constraint whose multiplier reaches what it constrains (its flows depend on its own effort, its efforts on its " \
    "own flow), or turns an orientation, or acts through a resistor")                                                         \
  X(kConstraintComplianceIgnored, "constraint.compliance_ignored", kWarning,                                                   \
    "compliances given to some ideal constraints but not to all: they are not used")                                           \
  X(kEventUnsupported, "event.unsupported", kModelError,                                                                       \
    "a contact or friction on a vector bond, or on a flow that is not held at zero; end stops or friction on a joint that is "  \
    "not revolute or prismatic")                                                                                               \
  X(kEventUnknownVariable, "event.unknown_variable", kModelError,                                                               \
    "a contact's gap or a friction's normal force that names no variable or signal of the model")                               \
  X(kEventDirection, "event.direction", kModelError,                                                                           \
    "a contact whose gap closes while its flow says it separates: its bond points the wrong way")                               \
  X(kMechReference, "mech.reference", kModelError, "a body, joint or gear mesh named that does not exist or cannot be used there") \
  X(kMechCoupling, "mech.coupling", kModelError, "a joint that couples nothing, or a coupling without 1 to 3 independent directions") \
  X(kMechDuplicate, "mech.duplicate", kModelError, "two bodies, joints, gear meshes, drives or points of one name")           \
  X(kMechName, "mech.name", kModelError, "a part of a mechanism named 'ground' (the inertial frame)")                         \
  X(kMechJointType, "mech.joint_type", kModelError, "a joint type that does not exist")                                   \
  X(kMechJointAxis, "mech.joint_axis", kModelError,                                                                           \
    "a joint type without the axis it needs (axis, normal, child_axis), or a universal joint whose yoke axes are not perpendicular") \
  X(kMechInitialGap, "mech.initial_gap", kWarning, "a joint whose attachment points are apart at t = 0")                     \
  X(kMechGearGeometry, "mech.gear_geometry", kModelError,                                                                     \
    "a gear mesh through its pitch point whose axes, radii and teeth do not roll together (a wrong axis sign, radii not in the ratio of the teeth, axes that do not meet)") \
  X(kMechGearSlip, "mech.gear_slip", kWarning, "a gear mesh whose teeth slip at the pitch point at t = 0 (initial speeds that do not roll)") \
  X(kMechAssembly, "mech.assembly", kModelError,                                                                             \
    "no assembly: the joints cannot all be closed at the given coordinates, or the given coordinates or speeds contradict each other") \
  X(kMechAssembled, "mech.assembled", kWarning, "what the assembly moved: per body the displacement, the turn and the change of velocity") \
  X(kOutputUnknownVariable, "output.unknown_variable", kModelError, "an output naming no variable (reported by run)")         \
  X(kOutputSize, "output.size", kModelError, "an output whose terms or point do not have the sizes it needs")                \
  X(kOutputDuplicate, "output.duplicate", kModelError, "two output columns of one name")                                     \
  X(kPlotList, "plot.list", kModelError, "a figure list (plot --figures) that is not a mapping, or has no figures") \
  X(kPlotType, "plot.type", kModelError, "a key of a figure list whose value has the wrong type (a list, a mapping, a number, text)") \
  X(kPlotUnknownKey, "plot.unknown_key", kModelError, "a key a figure list does not know there") \
  X(kPlotDuplicateKey, "plot.duplicate_key", kModelError, "a key given twice in one mapping of a figure list") \
  X(kPlotName, "plot.name", kModelError, "a figure name that is not a file name of letters, digits, '-' and '_', or is used twice") \
  X(kPlotPanels, "plot.panels", kModelError, "a figure with no panels, or with panels and a bond graph") \
  X(kPlotPanel, "plot.panel", kModelError, "a panel that does not fit its kind (a path without three columns, an orientation without a body)") \
  X(kPlotKind, "plot.kind", kModelError, "a panel kind other than time, path and orientation") \
  X(kPlotCurve, "plot.curve", kModelError, "a curve that names no column, or more than one way") \
  X(kPlotColumn, "plot.column", kModelError, "a column name of a figure list that is not a result column name") \
  X(kPlotColor, "plot.color", kModelError, "a colour that is not #rrggbb") \
  X(kPlotCheck, "plot.check", kModelError, "a check of a figure list without a column, a value or a positive tolerance") \
  X(kSweepStudy, "sweep.study", kUsage, "a study (sweep) of the wrong shape: an unknown key, a value of the wrong type, no model, nothing swept or kept") \
  X(kSweepUnknownParameter, "sweep.unknown_parameter", kUsage, "a swept or set parameter that the model does not declare") \
  X(kSweepRange, "sweep.range", kUsage, "an empty or reversed range, fewer than 2 grid points, a log scale through zero, an empty list") \
  X(kSweepDistribution, "sweep.distribution", kUsage, "an unknown distribution, or parameters that do not fit it (a reversed range, a negative deviation)") \
  X(kSweepSeed, "sweep.seed", kUsage, "a seed that is not a whole number from 0 to 2^64-1, or a number of samples that is not a positive whole number") \
  X(kSweepKeep, "sweep.keep", kUsage, "a kept quantity whose expression does not read or names no result column, or an unknown way to take it") \
  X(kInternalDoubleWriter, "internal.double_writer", kModelError,                                                              \
    "a variable computed twice: a causality conflict the analysis did not catch (a bug of multibond: please report it)")

#define MULTIBOND_DIAGNOSTIC_CODE_CONSTANT(id, code, outcome, meaning) inline constexpr const char id[] = code;
MULTIBOND_DIAGNOSTIC_CODES(MULTIBOND_DIAGNOSTIC_CODE_CONSTANT)
#undef MULTIBOND_DIAGNOSTIC_CODE_CONSTANT

struct CodeInfo {
  std::string_view code;
  Outcome outcome;
  std::string_view meaning;
};

#define MULTIBOND_DIAGNOSTIC_CODE_ROW(id, code, outcome, meaning) CodeInfo{code, Outcome::outcome, meaning},
inline constexpr CodeInfo kCatalogue[] = {MULTIBOND_DIAGNOSTIC_CODES(MULTIBOND_DIAGNOSTIC_CODE_ROW)};
#undef MULTIBOND_DIAGNOSTIC_CODE_ROW

/// The catalogue's entry for `code`, or nullptr.
const CodeInfo* Find(std::string_view code);

/// The code of the limit `limit` (an InputLimits name, e.g. "depth" -> "limit.depth"); empty if
/// that limit is not one a model file can exceed.
std::string_view LimitCode(std::string_view limit);

/// How `multibond` exits for a diagnostic of `code` (a code not in the catalogue, or none: a
/// model error).
Outcome OutcomeOf(std::string_view code);

}  // namespace multibond::codes
