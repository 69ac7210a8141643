#include "multibond/core/graph.h"

#include <algorithm>

#include <fmt/format.h>

#include "multibond/core/diagnostic_codes.h"

namespace multibond {

namespace {
constexpr std::pair<ElementKind, const char*> kKindNames[] = {
    {ElementKind::kSe, "Se"},   {ElementKind::kSf, "Sf"},   {ElementKind::kI, "I"},
    {ElementKind::kC, "C"},     {ElementKind::kR, "R"},     {ElementKind::kTF, "TF"},
    {ElementKind::kMTF, "MTF"}, {ElementKind::kGY, "GY"},   {ElementKind::kMGY, "MGY"},
    {ElementKind::kZero, "0"},  {ElementKind::kOne, "1"},
};
}  // namespace

const char* KindName(ElementKind k) {
  for (const auto& [kind, name] : kKindNames)
    if (kind == k) return name;
  return "?";
}

std::optional<ElementKind> ParseKind(const std::string& s) {
  for (const auto& [kind, name] : kKindNames)
    if (s == name) return kind;
  return std::nullopt;
}

bool IsJunction(ElementKind k) { return k == ElementKind::kZero || k == ElementKind::kOne; }
bool IsTwoPort(ElementKind k) {
  return k == ElementKind::kTF || k == ElementKind::kMTF || k == ElementKind::kGY || k == ElementKind::kMGY;
}
bool IsOnePort(ElementKind k) { return !IsJunction(k) && !IsTwoPort(k); }
bool IsSource(ElementKind k) { return k == ElementKind::kSe || k == ElementKind::kSf; }
bool IsStorage(ElementKind k) { return k == ElementKind::kI || k == ElementKind::kC; }

bool IsMultiportEnergy(const Element& e) { return IsStorage(e.kind) && e.energy.given() && e.dim > 1; }

std::vector<std::string> OwnVariables(ElementKind kind, int n) {
  const std::string base = kind == ElementKind::kI ? "p" : "q";
  if (n <= 1) return {base};
  std::vector<std::string> out;
  for (int k = 1; k <= n; ++k) out.push_back(base + std::to_string(k));
  return out;
}

std::vector<std::string> OwnVariables(const Element& e) { return OwnVariables(e.kind, IsMultiportEnergy(e) ? e.dim : 1); }

Eigen::MatrixXd Param::AsMatrix(int rows, int cols) const {
  if (is_scalar) return scalar * Eigen::MatrixXd::Identity(rows, cols);
  return matrix;
}

int Modulus::rows() const {
  if (left.size() > 0) return static_cast<int>(left.rows());
  if (kind == Kind::kConstant) return static_cast<int>(constant.rows());
  return 3;
}

int Modulus::cols() const {
  if (kind == Kind::kConstant) return static_cast<int>(constant.cols());
  if (kind == Kind::kRotation && right.size() > 0) return static_cast<int>(right.cols());
  return 3;
}

bool Modulus::invertible() const {
  if (rows() != cols()) return false;
  if (!entries.empty()) return rows() == 1;  // a changing 1 x 1 modulus is divided by; a matrix is not inverted
  if (kind == Kind::kLever) return false;  // a cross-product matrix is always singular
  if (left.size() > 0 && std::abs(left.determinant()) < 1e-300) return false;
  if (right.size() > 0 && std::abs(right.determinant()) < 1e-300) return false;
  if (kind == Kind::kConstant && std::abs(constant.determinant()) < 1e-300) return false;
  return scale != 0.0;
}

std::string Modulus::ToString() const {
  std::string s = scale == 1.0 ? "" : fmt::format("{:g} ", scale);
  if (left.size() > 0) s += "S ";
  switch (kind) {
    case Kind::kConstant: return s + "M";
    case Kind::kRotation: return s + (transpose ? "R(" + rotation + ")^T" : "R(" + rotation + ")");
    case Kind::kLever:
      return s + fmt::format("-[(R({}) [{:g} {:g} {:g}])x]", rotation, lever.x(), lever.y(), lever.z());
  }
  return s;
}

int BondGraph::Add(Element e) {
  const int id = static_cast<int>(elements_.size());
  const auto [it, fresh] = index_.try_emplace(e.name, id);  // one look-up, not three
  if (!fresh) {
    const Element& first = elements_[it->second];
    Diagnostic d;
    d.where = e.where;
    d.element = e.name;
    d.message = "duplicate element name";
    d.code = codes::kNameDuplicate;
    if (first.where.known()) d.details.push_back("first defined at " + first.where.ToString());
    d.hint = "give every element a unique name";
    throw ModelError(d);
  }
  elements_.push_back(std::move(e));
  return id;
}

static Element MakeElement(const std::string& name, ElementKind kind, int dim) {
  Element e;
  e.name = name;
  e.kind = kind;
  e.dim = dim;
  return e;
}

int BondGraph::AddSe(const std::string& name, SourceValue v, int dim) {
  Element e = MakeElement(name, ElementKind::kSe, dim);
  e.source = std::move(v);
  return Add(std::move(e));
}
int BondGraph::AddSf(const std::string& name, SourceValue v, int dim) {
  Element e = MakeElement(name, ElementKind::kSf, dim);
  e.source = std::move(v);
  return Add(std::move(e));
}
int BondGraph::AddI(const std::string& name, Param inertia, int dim) {
  Element e = MakeElement(name, ElementKind::kI, dim);
  e.param = std::move(inertia);
  return Add(std::move(e));
}
int BondGraph::AddC(const std::string& name, Param stiffness, int dim) {
  Element e = MakeElement(name, ElementKind::kC, dim);
  e.param = std::move(stiffness);
  return Add(std::move(e));
}
int BondGraph::AddR(const std::string& name, Param resistance, int dim) {
  Element e = MakeElement(name, ElementKind::kR, dim);
  e.param = std::move(resistance);
  return Add(std::move(e));
}
int BondGraph::AddTF(const std::string& name, Param ratio) {
  Element e = MakeElement(name, ElementKind::kTF, 0);
  e.param = std::move(ratio);
  return Add(std::move(e));
}
int BondGraph::AddGY(const std::string& name, Param ratio) {
  Element e = MakeElement(name, ElementKind::kGY, 0);
  e.param = std::move(ratio);
  return Add(std::move(e));
}
int BondGraph::AddMTF(const std::string& name, Modulus m) {
  Element e = MakeElement(name, ElementKind::kMTF, 0);
  e.modulus = std::move(m);
  return Add(std::move(e));
}
int BondGraph::AddMGY(const std::string& name, Modulus m) {
  Element e = MakeElement(name, ElementKind::kMGY, 0);
  e.modulus = std::move(m);
  return Add(std::move(e));
}
int BondGraph::AddJunction(const std::string& name, ElementKind zero_or_one, int dim) {
  MB_ASSERT(IsJunction(zero_or_one), "AddJunction takes kZero or kOne");
  return Add(MakeElement(name, zero_or_one, dim));
}

int BondGraph::Connect(const std::string& from, const std::string& to, int dim, std::string bond_name,
                       SourceLocation where) {
  DiagnosticSink sink;
  const int a = Find(from), b = Find(to);
  if (a < 0) sink.Error(codes::kBondUnknownEnd, where, from, "bond refers to an element that does not exist", "define '" + from + "' under elements");
  if (b < 0) sink.Error(codes::kBondUnknownEnd, where, to, "bond refers to an element that does not exist", "define '" + to + "' under elements");
  if (a >= 0 && a == b) sink.Error(codes::kBondSelf, where, from, "bond connects an element to itself");
  sink.ThrowIfErrors();
  Bond bond;
  bond.name = bond_name.empty() ? fmt::format("{}->{}", from, to) : std::move(bond_name);
  bond.from = a;
  bond.to = b;
  bond.dim = dim;
  bond.where = std::move(where);
  const int id = static_cast<int>(bonds_.size());
  bonds_.push_back(std::move(bond));
  elements_[a].bonds.push_back(id);
  elements_[b].bonds.push_back(id);
  return id;
}

void BondGraph::Reserve(int elements, int bonds) {
  elements_.reserve(static_cast<size_t>(std::max(elements, 0)));
  index_.reserve(static_cast<size_t>(std::max(elements, 0)));
  bonds_.reserve(static_cast<size_t>(std::max(bonds, 0)));
}

int BondGraph::AddAux(AuxState a) {
  if (aux_index_.count(a.name) || index_.count(a.name)) {
    Diagnostic d;
    d.where = a.where;
    d.element = a.name;
    d.message = "duplicate name (an element or state of that name exists already)";
    d.code = codes::kNameDuplicate;
    d.hint = "give every element and state a unique name";
    throw ModelError(d);
  }
  const int id = static_cast<int>(aux_.size());
  aux_index_[a.name] = id;
  aux_.push_back(std::move(a));
  return id;
}

int BondGraph::AddSignal(Signal s) {
  if (signal_index_.count(s.name) || aux_index_.count(s.name) || index_.count(s.name)) {
    Diagnostic d;
    d.where = s.where;
    d.element = s.name;
    d.message = "duplicate name (an element, state or signal of that name exists already)";
    d.code = codes::kNameDuplicate;
    d.hint = "give every element, state and signal a unique name";
    throw ModelError(d);
  }
  const int id = static_cast<int>(signals_.size());
  signal_index_[s.name] = id;
  signals_.push_back(std::move(s));
  return id;
}

int BondGraph::FindSignal(const std::string& name) const {
  auto it = signal_index_.find(name);
  return it == signal_index_.end() ? -1 : it->second;
}

int BondGraph::Find(const std::string& name) const {
  const auto it = index_.find(name);
  return it == index_.end() ? -1 : it->second;
}

int BondGraph::FindAux(const std::string& name) const {
  const auto it = aux_index_.find(name);
  return it == aux_index_.end() ? -1 : it->second;
}

int BondGraph::Other(int b, int e) const {
  const Bond& bond = bonds_.at(b);
  return bond.from == e ? bond.to : bond.from;
}

int BondGraph::PowerSign(int b, int e) const { return bonds_.at(b).to == e ? +1 : -1; }

}  // namespace multibond
