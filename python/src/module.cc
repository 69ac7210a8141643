// The Python module multibond._multibond (pybind11): the library's layers behind a small Python
// API (python/multibond/__init__.py adds the pure-Python part). A model is loaded with the
// loader (io), compiled (compile), run by the simulator (sim) with the GIL released, and
// analysed by the analysis layer (linearize, modes, bode), each through the same calls as the
// command line (apps/multibond/). Results keep every row in one row-major buffer; a column is a
// strided, read-only NumPy view of it that keeps the Results alive (no copy).

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "multibond/analysis/bode.h"
#include "multibond/analysis/linear_files.h"
#include "multibond/analysis/linearize.h"
#include "multibond/analysis/modes.h"
#include "multibond/api/lookup.h"
#include "multibond/api/run_options.h"
#include "multibond/compile/compiled_model.h"
#include "multibond/compile/equations.h"
#include "multibond/compile/generated_rhs.h"
#include "multibond/core/interrupt.h"
#include "multibond/io/model_loader.h"
#include "multibond/io/results_writer.h"
#include "multibond/sim/simulator.h"
#include "multibond/sweep/sweep.h"
#include "multibond/version.h"

namespace py = pybind11;

namespace multibond::python {

namespace {

// --- Errors: multibond.ModelError, SimulationError (python/multibond/_errors.py) -------------

py::object ErrorsModule() { return py::module_::import("multibond._errors"); }

const char* SeverityName(Diagnostic::Severity s) { return s == Diagnostic::Severity::kError ? "error" : "warning"; }

py::object ToPython(const Diagnostic& d) {
  return ErrorsModule().attr("Diagnostic")(py::arg("file") = d.where.file, py::arg("line") = d.where.line,
                                           py::arg("column") = d.where.column, py::arg("element") = d.element,
                                           py::arg("code") = d.code, py::arg("message") = d.message, py::arg("hint") = d.hint,
                                           py::arg("details") = d.details, py::arg("severity") = SeverityName(d.severity),
                                           py::arg("text") = d.ToString());
}

py::list ToPython(const std::vector<Diagnostic>& ds) {
  py::list out;
  for (const Diagnostic& d : ds) out.append(ToPython(d));
  return out;
}

/// Sets multibond.ModelError as the Python error (in an exception translator).
void RaiseModelError(const ModelError& e) {
  const py::object cls = ErrorsModule().attr("ModelError");
  const py::object exc = cls(e.what(), ToPython(e.diagnostics()));
  PyErr_SetObject(cls.ptr(), exc.ptr());
}

py::object JsonToPython(const nlohmann::json& j) { return py::module_::import("json").attr("loads")(DumpRecord(j)); }

// --- Ctrl-C ------------------------------------------------------------------------------------
// Python's own SIGINT handler only sets a flag that the main thread's interpreter looks at between
// bytecodes: a run with the GIL released would not see it. While the main thread runs a model,
// SIGINT sets the run's stop flag instead (the simulator stops at its next evaluation, keeping
// the rows it computed, as `multibond run` does with core/interrupt.h's handlers); Python's
// handler is then put back and the interrupt handed to it (KeyboardInterrupt, or whatever the
// program's SIGINT handler does). Runs in other threads are not stopped by Ctrl-C: Python
// delivers it to the main thread only.

std::atomic<bool> g_sigint{false};
static_assert(std::atomic<bool>::is_always_lock_free);
unsigned long g_main_thread = 0;

extern "C" void OnSigint(int) { g_sigint.store(true); }

bool OnMainThread() { return PyThread_get_thread_ident() == g_main_thread; }

/// While it lives on the main thread: SIGINT sets g_sigint. Created with the GIL held.
class SigintScope {
 public:
  SigintScope() : active_(OnMainThread()) {
    if (!active_) return;
    g_sigint.store(false);
    struct sigaction sa {};
    sa.sa_handler = OnSigint;
    sigemptyset(&sa.sa_mask);
    active_ = sigaction(SIGINT, &sa, &previous_) == 0;
  }
  ~SigintScope() {
    if (active_) sigaction(SIGINT, &previous_, nullptr);
  }
  SigintScope(const SigintScope&) = delete;
  SigintScope& operator=(const SigintScope&) = delete;
  const std::atomic<bool>* flag() const { return active_ ? &g_sigint : nullptr; }
  /// After the run (GIL held, handler restored): hands a Ctrl-C to Python's handler. Returns
  /// true when that raised (the Python error is set).
  bool Deliver() {
    if (!active_) return false;
    sigaction(SIGINT, &previous_, nullptr);
    active_ = false;
    if (!g_sigint.exchange(false)) return false;
    PyErr_SetInterruptEx(SIGINT);
    return PyErr_CheckSignals() != 0;
  }

 private:
  bool active_;
  struct sigaction previous_ {};
};

// --- Results ---------------------------------------------------------------------------------

struct PyResults {
  std::vector<std::string> names, units;
  std::vector<double> data;  ///< row-major: rows x names.size()
  std::size_t rows = 0;
  RunSummary summary;
  std::vector<EventRecord> events;  ///< the run's events (docs/events.md), as events.csv lists them
  /// For the run record (Results.meta), made when first asked for.
  std::shared_ptr<const std::string> model_file, model_text;
  std::string model_name, solver, coordinates, rhs_engine;
  RunOptions options;
  nlohmann::json parameters;
  std::optional<py::object> meta;

  std::size_t Index(const std::string& name) const {
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) {
      try {
        ThrowUnknownName("column", name, names);
      } catch (const std::invalid_argument& e) {
        throw py::key_error(e.what());
      }
    }
    return static_cast<std::size_t>(it - names.begin());
  }
};

/// Keeps a run's rows in one row-major buffer, reserved for the rows the run will give.
class RowRecorder : public Observer {
 public:
  RowRecorder(PyResults& r, std::size_t expected_rows) : r_(r), expected_rows_(expected_rows) {}
  void OnStart(const std::vector<Column>& columns) override {
    for (const Column& c : columns) {
      r_.names.push_back(c.name);
      r_.units.push_back(c.unit);
    }
    // At most 256 MiB ahead; a longer run grows as it goes.
    const std::size_t cap = (std::size_t{1} << 25) / std::max<std::size_t>(columns.size(), 1);
    r_.data.reserve(std::min(expected_rows_, cap) * columns.size());
  }
  void OnSample(const std::vector<double>& row) override {
    r_.data.insert(r_.data.end(), row.begin(), row.end());
    ++r_.rows;
  }
  void OnFinish(const RunSummary& s) override { r_.summary = s; }
  void OnEvent(const EventRecord& e) override { r_.events.push_back(e); }

 private:
  PyResults& r_;
  std::size_t expected_rows_;
};

py::array ReadOnlyView(const py::object& owner, const double* data, std::vector<py::ssize_t> shape, std::vector<py::ssize_t> strides) {
  py::array a(py::dtype::of<double>(), std::move(shape), std::move(strides), data, owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

py::array ColumnView(const py::object& self, const std::string& name) {
  const PyResults& r = self.cast<const PyResults&>();
  const std::size_t c = r.Index(name);
  static const double empty = 0.0;
  const double* base = r.data.empty() ? &empty : r.data.data() + c;
  return ReadOnlyView(self, base, {static_cast<py::ssize_t>(r.rows)},
                      {static_cast<py::ssize_t>(r.names.size() * sizeof(double))});
}

py::array TableView(const py::object& self) {
  const PyResults& r = self.cast<const PyResults&>();
  static const double empty = 0.0;
  const auto n = static_cast<py::ssize_t>(r.names.size());
  return ReadOnlyView(self, r.data.empty() ? &empty : r.data.data(), {static_cast<py::ssize_t>(r.rows), n},
                      {n * static_cast<py::ssize_t>(sizeof(double)), static_cast<py::ssize_t>(sizeof(double))});
}

py::object Meta(PyResults& r) {
  if (r.meta) return *r.meta;
  nlohmann::json j = MakeRunRecord(*r.model_file, *r.model_text, r.model_name, r.options, r.summary, {});
  j["command"] = "python: multibond.Model.run";
  j["rhs_engine"] = r.rhs_engine;
  j["options"]["solver"] = r.solver;
  j["options"]["coordinates"] = r.coordinates;
  j["parameters"] = r.parameters;
  r.meta = JsonToPython(j);
  return *r.meta;
}

// --- Model -----------------------------------------------------------------------------------

struct PyModel {
  LoadedModel lm;
  InputLimits limits;
  std::string jit = "auto";
  std::shared_ptr<const std::string> file, text;  ///< shared with the Results of its runs
  /// lm.graph compiled, with its generated code (jit auto or on), made on first use.
  struct Built {
    std::shared_ptr<const CompiledModel> model;
    std::shared_ptr<const GeneratedRhs> code;
  } built;
};

std::vector<ParameterOverride> Overrides(const std::vector<std::pair<std::string, std::string>>& values) {
  std::vector<ParameterOverride> out;
  for (const auto& [name, value] : values) out.push_back({name, value});
  return out;
}

std::unique_ptr<PyModel> MakeModel(LoadedModel lm, const std::string& jit, const std::optional<std::string>& constraints,
                                 const std::optional<std::string>& loops) {
  if (jit != "auto" && jit != "on" && jit != "off") throw std::invalid_argument("jit must be 'auto', 'on' or 'off' (got '" + jit + "')");
  if (constraints && *constraints != "ideal" && *constraints != "compliant")
    throw std::invalid_argument("constraints must be 'ideal' or 'compliant' (got '" + *constraints + "')");
  if (loops && *loops != "solve" && *loops != "error")
    throw std::invalid_argument("algebraic_loops must be 'solve' or 'error' (got '" + *loops + "')");
  auto m = std::make_unique<PyModel>();
  m->lm = std::move(lm);
  m->jit = jit;
  if (constraints) m->lm.compile.ideal_constraints = *constraints == "ideal";  // as --constraints
  if (loops) m->lm.compile.solve_algebraic_loops = *loops == "solve";          // as --algebraic-loops
  m->file = std::make_shared<const std::string>(m->lm.file);
  m->text = std::make_shared<const std::string>(m->lm.text);
  return m;
}

/// Compiles `graph` as the model's options say, with the GIL released (a compile may run the
/// system compiler for seconds).
PyModel::Built Compile(const PyModel& m, BondGraph graph) {
  PyModel::Built b;
  {
    py::gil_scoped_release nogil;
    b.model = CompiledModel::Compile(std::move(graph), m.lm.compile);
    if (m.jit != "off") b.code = GeneratedRhs::Start(b.model);
  }
  if (m.jit == "on" && !b.code->uses_generated_code()) throw std::runtime_error("jit 'on', but " + b.code->engine());
  return b;
}

const PyModel::Built& Compiled(PyModel& m) {
  if (!m.built.model) m.built = Compile(m, m.lm.graph);
  return m.built;
}

/// An element's parameter, as the C++ API's Model::SetParameter sets it: I inertia, C
/// stiffness, R resistance, TF/GY ratio (a scalar: scalar x identity), or a source's constant
/// value (each component). `value`: a number, a sequence (a source's components) or a matrix.
void SetElementParameter(BondGraph& g, const std::string& name, const py::handle& value) {
  const int i = g.Find(name);
  if (i < 0) {
    std::vector<std::string> names;
    for (const Element& e : g.elements()) names.push_back(e.name);
    ThrowUnknownName("element", name, names);
  }
  Element& e = g.element(i);
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(value);
  if (!a) throw std::invalid_argument(fmt::format("the value for '{}' is not a number or an array of numbers", name));
  if (a.ndim() > 2 || a.size() == 0) throw std::invalid_argument(fmt::format("the value for '{}' must be a number, a vector or a matrix", name));
  const double* v = a.data();
  if (IsSource(e.kind)) {
    if (a.ndim() == 2 && a.shape(0) != 1 && a.shape(1) != 1)
      throw std::invalid_argument(fmt::format("source '{}' takes a value per component, not a matrix", name));
    e.source.components.clear();
    for (py::ssize_t k = 0; k < a.size(); ++k) e.source.components.push_back(TimeFunction::Constant(v[k]));
    return;
  }
  switch (e.kind) {
    case ElementKind::kI:
    case ElementKind::kC:
    case ElementKind::kR:
    case ElementKind::kTF:
    case ElementKind::kGY: break;
    default:
      throw std::invalid_argument(fmt::format("element '{}' ({}) has no parameter to set (I, C, R, TF, GY and sources have)", name,
                                              KindName(e.kind)));
  }
  if (a.ndim() == 0 || a.size() == 1) {
    e.param = Param::Scalar(v[0]);
    return;
  }
  if (a.ndim() != 2) throw std::invalid_argument(fmt::format("'{}' takes a number or a matrix (a list of rows)", name));
  Eigen::MatrixXd mat(a.shape(0), a.shape(1));
  for (py::ssize_t r = 0; r < a.shape(0); ++r)
    for (py::ssize_t c = 0; c < a.shape(1); ++c) mat(r, c) = v[r * a.shape(1) + c];
  e.param = Param::Matrix(std::move(mat));
}

struct RunArgs {
  std::optional<double> t_end, dt, rtol, atol, step, max_step;
  std::optional<std::string> solver, coordinates;
  std::string jacobian = "auto";
  bool project = true, all_variables = false;
};

SimulationOptions ToSimulationOptions(const RunArgs& a) {
  SimulationOptions o;
  o.t_end = a.t_end;
  o.dt = a.dt;
  o.solver = a.solver;
  o.rtol = a.rtol;
  o.atol = a.atol;
  o.step = a.step;
  o.max_step = a.max_step;
  o.coordinates = a.coordinates;
  o.jacobian = a.jacobian;
  o.project = a.project;
  o.all_variables = a.all_variables;
  return o;
}

/// Simulates with the GIL released and Ctrl-C stopping the run. Returns false when a Ctrl-C was
/// handed to Python and raised there (the Python error is set).
bool SimulateReleased(const CompiledModel& model, RunOptions& o, Observer& observer, RunSummary& summary) {
  SigintScope sigint;
  if (!o.stop) o.stop = sigint.flag();
  {
    py::gil_scoped_release nogil;
    summary = Simulate(model, o, observer);
  }
  o.stop = nullptr;
  return !sigint.Deliver();
}

py::object Run(py::object self, const RunArgs& a, const py::object& set) {
  PyModel& m = self.cast<PyModel&>();
  PyModel::Built b;
  if (set.is_none() || py::len(set) == 0) {
    b = Compiled(m);
  } else {  // this run only: the model keeps its own values
    BondGraph g = m.lm.graph;
    for (const auto& [k, v] : set.cast<py::dict>()) SetElementParameter(g, k.cast<std::string>(), v);
    b = Compile(m, std::move(g));
  }
  const std::shared_ptr<const CompiledModel>& model = b.model;
  RunOptions o = ResolveRunOptions(m.lm, ToSimulationOptions(a), m.limits);
  o.code = b.code;
  auto holder = std::make_unique<PyResults>();
  PyResults& r = *holder;
  r.model_file = m.file;
  r.model_text = m.text;
  r.model_name = m.lm.graph.name();
  r.solver = a.solver.value_or(m.lm.simulation.solver.value_or(kDefaultSolver));
  r.coordinates = o.joint_coordinates.empty() ? "inertial" : "joint";
  r.rhs_engine = RhsEngine(b.code.get());
  r.parameters = nlohmann::json::object();
  for (const ModelParameter& q : m.lm.parameters) r.parameters[q.name] = {{"value", q.value}, {"unit", q.unit}, {"set", q.set}};
  CheckRunOptions(*model, o);  // before the rows are counted
  RowRecorder recorder(r, static_cast<std::size_t>(NumOutputIntervals(o)) + 1);
  RunSummary summary;
  const bool completed = SimulateReleased(*model, o, recorder, summary);
  r.summary = summary;
  r.options = o;
  py::object results = py::cast(std::move(holder));
  if (!completed) {  // KeyboardInterrupt (or the program's own SIGINT handler's error), with the rows
    py::error_already_set e;
    e.value().attr("results") = results;
    throw e;
  }
  if (summary.status == RunStatus::kFailed) {
    const py::object cls = ErrorsModule().attr("SimulationError");
    const py::object exc = cls(summary.message, results);
    PyErr_SetObject(cls.ptr(), exc.ptr());
    throw py::error_already_set();
  }
  return results;
}

// --- Linear analysis -------------------------------------------------------------------------

/// The linear model about the state at `at` (a run from the start, as `multibond linearize --at`)
/// or the initial state, then, with `steady`, the steady state found from there (--steady).
linear::LinearModel LinearizeAt(PyModel& m, std::optional<double> at, bool steady, const RunArgs& a) {
  const PyModel::Built& b = Compiled(m);
  const std::shared_ptr<const CompiledModel> model = b.model;
  RunOptions o = ResolveRunOptions(m.lm, ToSimulationOptions(a), m.limits);
  o.code = b.code;
  double t = o.t_start;
  Eigen::VectorXd x = model->MakeInitialState();
  if (at && *at != o.t_start) {
    o = linear::RunToOperatingPoint(o, *at, "at =");
    linear::FinalState last;
    RunSummary summary;
    if (!SimulateReleased(*model, o, last, summary)) throw py::error_already_set();
    if (summary.status != RunStatus::kOk) {
      const py::object cls = ErrorsModule().attr("SimulationError");
      const py::object exc = cls(fmt::format("the run to the operating point at t = {:g} s stopped: {}", *at, summary.message), py::none());
      PyErr_SetObject(cls.ptr(), exc.ptr());
      throw py::error_already_set();
    }
    t = *at;
    x = last.State(model->num_states());
  }
  py::gil_scoped_release nogil;
  if (steady) x = linear::FindSteadyState(*model, t, x);
  linear::LinearModel lm = linear::Linearize(*model, t, x);
  lm.steady = steady;
  return lm;
}

/// What linear.json records beside the linear model (the command line's records its run).
nlohmann::json LinearRecord(const char* command) {
  nlohmann::json record = nlohmann::json::object();
  record["command"] = std::string("python: multibond.Model.") + command;
  record["version"] = std::string(kVersion);
  return record;
}

int FindName(const std::vector<std::string>& names, const std::string& name, const char* what) {
  const auto it = std::find(names.begin(), names.end(), name);
  if (it == names.end()) ThrowUnknownName(what, name, names);
  return static_cast<int>(it - names.begin());
}

// --- check -----------------------------------------------------------------------------------

py::dict Check(PyModel& m) {
  py::dict out;
  try {
    const std::shared_ptr<const CompiledModel> model = Compiled(m).model;
    (void)MakeColumns(*model, false);  // and the declared outputs, as `multibond check`
    py::list states;
    for (int i = 0; i < model->num_states(); ++i)
      states.append(py::make_tuple(model->state_names()[i], model->state_units()[i]));
    py::list loops;
    for (const auto& loop : model->algebraic_loops()) loops.append(py::make_tuple(loop.path, loop.torn));
    out["ok"] = true;
    out["states"] = states;
    out["conflicts"] = py::list();
    out["algebraic_loops"] = loops;
    out["constraint_efforts"] = model->num_multipliers();
  } catch (const ModelError& e) {
    out["ok"] = false;
    out["states"] = py::list();
    out["conflicts"] = ToPython(e.diagnostics());
    out["algebraic_loops"] = py::list();
    out["constraint_efforts"] = 0;
  }
  out["warnings"] = ToPython(m.lm.warnings);
  return out;
}

/// multibond.sweep (docs/sweeps.md): the study of `a` run into `out` on `threads` threads with
/// the GIL released (Ctrl-C on the main thread stops it; the journal keeps what finished).
/// Returns sweep.csv's path; the Python side reads it into a DataFrame.
std::string Sweep(const sweep::StudyArguments& a, const std::string& out, int threads, bool resume, const std::string& jit,
                  const SimulationOptions& given) {
  if (jit != "auto" && jit != "on" && jit != "off") throw std::invalid_argument("jit must be 'auto', 'on' or 'off' (got '" + jit + "')");
  const InputLimits limits;
  DiagnosticSink problems;
  std::string model_text;
  const sweep::Study study = sweep::StudyFromArguments(a, limits, problems, model_text);
  sweep::Runner runner(study, model_text, limits, jit, problems);
  SimulationOptions o = given;
  if (!o.t_end) o.t_end = study.t_end;
  if (!o.dt) o.dt = study.dt;
  if (!o.rtol) o.rtol = study.rtol;
  if (!o.atol) o.atol = study.atol;
  if (!o.solver) o.solver = study.solver;
  runner.set_run_options(ResolveRunOptions(runner.nominal(), o, limits));
  sweep::SweepOptions so;
  so.dir = out;
  so.threads = threads;
  so.resume = resume;
  SigintScope sigint;
  so.stop = sigint.flag();
  {
    py::gil_scoped_release nogil;
    sweep::RunSweep(study, runner, model_text, so, nullptr);
  }
  if (sigint.Deliver()) throw py::error_already_set();
  return (std::filesystem::path(out) / "sweep.csv").string();
}

}  // namespace

}  // namespace multibond::python

PYBIND11_MODULE(_multibond, mod) {
  using namespace multibond;
  using namespace multibond::python;
  mod.doc() = "multibond's library: load, run and analyse bond-graph models (use the package multibond)";
  mod.attr("__version__") = std::string(kVersion);
  g_main_thread = py::module_::import("threading").attr("main_thread")().attr("ident").cast<unsigned long>();

  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const ModelError& e) {
      RaiseModelError(e);
    } catch (const Interrupted& e) {
      PyErr_SetString(PyExc_KeyboardInterrupt, e.what());
    }
  });

  py::class_<PyResults>(mod, "Results", "The output of a run: columns by name, as results.csv has them")
      .def("__getitem__", &ColumnView, py::arg("column"), "A column as a read-only NumPy view of the results (no copy)")
      .def("__contains__", [](const PyResults& r, const std::string& n) { return std::find(r.names.begin(), r.names.end(), n) != r.names.end(); })
      .def("__len__", [](const PyResults& r) { return r.rows; })
      .def_property_readonly("time", [](const py::object& self) { return ColumnView(self, "time"); })
      .def_property_readonly("array", &TableView, "every row, rows x columns, a read-only NumPy view (no copy)")
      .def_property_readonly("columns", [](const PyResults& r) { return r.names; })
      .def_property_readonly("units", [](const PyResults& r) {
        py::dict d;
        for (std::size_t i = 0; i < r.names.size(); ++i) d[py::str(r.names[i])] = r.units[i];
        return d;
      })
      .def_property_readonly("status", [](const PyResults& r) { return RunStatusName(r.summary.status); })
      .def_property_readonly("ok", [](const PyResults& r) { return r.summary.status == RunStatus::kOk; })
      .def_property_readonly("message", [](const PyResults& r) { return r.summary.message; })
      .def_property_readonly("t_reached", [](const PyResults& r) { return r.summary.t_reached; })
      .def_property_readonly("warnings", [](const PyResults& r) { return r.summary.warnings; })
      .def_property_readonly("meta", &Meta, "the run record (run.json's content, without the results file's entry)")
      .def_property_readonly(
          "events",
          [](const PyResults& r) {
            py::list out;
            for (const EventRecord& e : r.events) {
              py::dict d;
              d["time"] = e.time;
              d["kind"] = e.kind;
              d["element"] = e.element;
              d["description"] = e.description;
              out.append(d);
            }
            return out;
          },
          "the run's events (docs/events.md): dicts with time, kind, element, description, as events.csv")
      .def("__repr__", [](const PyResults& r) {
        return fmt::format("<multibond.Results {}: {} rows x {} columns, t = 0..{:g} s>", RunStatusName(r.summary.status), r.rows,
                           r.names.size(), r.summary.t_reached);
      });

  mod.def(
      "_sweep",
      [](const std::string& path, const std::string& out, std::vector<std::string> grids, std::vector<std::string> lists,
         std::vector<std::string> samples_of, std::vector<std::string> keeps, std::optional<long> samples, std::optional<std::uint64_t> seed,
         std::optional<std::string> method, const std::vector<std::pair<std::string, std::string>>& set, int threads, bool resume,
         const std::string& jit, std::optional<double> t_end, std::optional<double> dt, std::optional<std::string> solver,
         std::optional<double> rtol, std::optional<double> atol, bool results) {
        sweep::StudyArguments a{path, std::move(grids), std::move(lists), std::move(samples_of), std::move(keeps), samples, seed, std::move(method),
                                set, results};
        SimulationOptions o;
        o.t_end = t_end;
        o.dt = dt;
        o.solver = std::move(solver);
        o.rtol = rtol;
        o.atol = atol;
        return Sweep(a, out, threads, resume, jit, o);
      },
      py::arg("path"), py::arg("out"), py::arg("grids"), py::arg("lists"), py::arg("samples_of"), py::arg("keeps"), py::arg("samples"),
      py::arg("seed"), py::arg("method"), py::arg("set"), py::arg("threads"), py::arg("resume"), py::arg("jit"), py::arg("t_end"), py::arg("dt"),
      py::arg("solver"), py::arg("rtol"), py::arg("atol"), py::arg("results"));
  py::class_<PyModel>(mod, "Model", "A model loaded from YAML (docs/model-format.md)")
      .def_static("_load",
                  [](const std::string& path, const std::vector<std::pair<std::string, std::string>>& parameters, const std::string& jit,
                     const std::optional<std::string>& constraints, const std::optional<std::string>& loops) {
                    return MakeModel(LoadModelFile(path, {}, Overrides(parameters)), jit, constraints, loops);
                  })
      .def_static("_loads",
                  [](const std::string& yaml, const std::string& file, const std::vector<std::pair<std::string, std::string>>& parameters,
                     const std::string& jit, const std::optional<std::string>& constraints, const std::optional<std::string>& loops) {
                    return MakeModel(LoadModelString(yaml, file, {}, Overrides(parameters)), jit, constraints, loops);
                  })
      .def_property_readonly("name", [](const PyModel& m) { return m.lm.graph.name(); })
      .def_property_readonly("file", [](const PyModel& m) { return m.lm.file; })
      .def_property_readonly("warnings", [](const PyModel& m) { return ToPython(m.lm.warnings); })
      .def_property_readonly("elements", [](const PyModel& m) {
        std::vector<std::string> names;
        for (const Element& e : m.lm.graph.elements()) names.push_back(e.name);
        return names;
      })
      .def_property_readonly("parameters", [](const PyModel& m) {
        py::dict d;
        for (const ModelParameter& q : m.lm.parameters) d[py::str(q.name)] = q.value;
        return d;
      })
      .def_property_readonly("state_names", [](py::object self) { return Compiled(self.cast<PyModel&>()).model->state_names(); })
      .def_property_readonly("rhs_engine", [](py::object self) { return RhsEngine(Compiled(self.cast<PyModel&>()).code.get()); })
      .def(
          "column_names", [](PyModel& m, bool all_variables) {
            std::vector<std::string> names;
            for (const Column& c : MakeColumns(*Compiled(m).model, all_variables)) names.push_back(c.name);
            return names;
          },
          py::arg("all_variables") = false)
      .def(
          "set_parameter", [](PyModel& m, const std::string& element, const py::object& value) {
            SetElementParameter(m.lm.graph, element, value);
            m.built = {};
          },
          py::arg("element"), py::arg("value"))
      .def(
          "_run",
          [](py::object self, std::optional<double> t_end, std::optional<double> dt, std::optional<std::string> solver,
             std::optional<double> rtol, std::optional<double> atol, std::optional<double> step, std::optional<double> max_step,
             std::optional<std::string> coordinates, std::string jacobian, bool project, bool all_variables, py::object set) {
            const RunArgs a{t_end, dt, rtol, atol, step, max_step, solver, coordinates, jacobian, project, all_variables};
            return Run(std::move(self), a, set);
          },
          py::arg("t_end"), py::arg("dt"), py::arg("solver"), py::arg("rtol"), py::arg("atol"), py::arg("step"), py::arg("max_step"),
          py::arg("coordinates"), py::arg("jacobian"), py::arg("project"), py::arg("all_variables"), py::arg("set"))
      .def("check", &Check, "causality: the state variables, or the conflicts")
      .def(
          "equations", [](PyModel& m, const std::string& format) {
            if (format != "text" && format != "latex") throw std::invalid_argument("format must be 'text' or 'latex' (got '" + format + "')");
            return FormatEquations(*Compiled(m).model, format == "latex" ? EquationFormat::kLatex : EquationFormat::kText);
          },
          py::arg("format") = "text")
      .def(
          "_linearize",
          [](PyModel& m, std::optional<double> at, bool steady, std::optional<double> t_end, std::optional<std::string> solver,
             std::optional<double> rtol, std::optional<double> atol) {
            RunArgs a;
            a.t_end = t_end;
            a.solver = solver;
            a.rtol = rtol;
            a.atol = atol;
            const linear::LinearModel lm = LinearizeAt(m, at, steady, a);
            return JsonToPython(linear::LinearJson(lm, LinearRecord("linearize")));
          },
          py::arg("at"), py::arg("steady"), py::arg("t_end"), py::arg("solver"), py::arg("rtol"), py::arg("atol"))
      .def(
          "_modes",
          [](PyModel& m, std::optional<double> at, bool steady, std::optional<double> t_end) {
            RunArgs a;
            a.t_end = t_end;
            const linear::LinearModel lm = LinearizeAt(m, at, steady, a);
            std::vector<linear::Mode> modes;
            {
              py::gil_scoped_release nogil;
              modes = linear::ComputeModes(lm);
            }
            py::dict out;
            out["modes"] = JsonToPython(linear::ModesJson(modes, lm))["modes"];
            out["table"] = linear::ModesTable(modes);
            return out;
          },
          py::arg("at"), py::arg("steady"), py::arg("t_end"))
      .def(
          "_bode",
          [](PyModel& m, const std::string& input, const std::string& output, std::optional<std::vector<double>> freqs,
             std::optional<double> at, bool steady, std::optional<double> t_end) {
            RunArgs a;
            a.t_end = t_end;
            const linear::LinearModel lm = LinearizeAt(m, at, steady, a);
            const int in = FindName(lm.inputs, input, "input");
            const int out = FindName(lm.outputs, output, "output");
            const std::vector<double> f = freqs ? *freqs : linear::DefaultFrequencies(lm);
            const std::vector<linear::BodePoint> points = linear::FrequencyResponse(lm, in, out, f);
            const auto n = static_cast<py::ssize_t>(points.size());
            py::array_t<double> hz(n), db(n), deg(n);
            py::array_t<std::complex<double>> g(n);
            for (py::ssize_t k = 0; k < n; ++k) {
              hz.mutable_at(k) = points[k].frequency_hz;
              db.mutable_at(k) = points[k].magnitude_db;
              deg.mutable_at(k) = points[k].phase_deg;
              g.mutable_at(k) = points[k].value;
            }
            py::dict d;
            d["frequency_hz"] = hz;
            d["magnitude_db"] = db;
            d["phase_deg"] = deg;
            d["response"] = g;
            d["input"] = input;
            d["output"] = output;
            return d;
          },
          py::arg("input"), py::arg("output"), py::arg("freqs"), py::arg("at"), py::arg("steady"), py::arg("t_end"));
}
