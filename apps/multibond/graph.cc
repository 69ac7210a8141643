// multibond graph: the bond graph with causal strokes, as Graphviz DOT and SVG or PNG.

#include <algorithm>
#include <cctype>
#include <iostream>
#include <memory>

#include <fmt/format.h>

#include "cli.h"
#include "multibond/causality/causality.h"
#include "multibond/causality/repair.h"
#include "multibond/core/structure.h"
#include "multibond/io/atomic_file.h"
#include "multibond/io/dot_writer.h"
#include "multibond/io/plots.h"

namespace multibond::cli {

namespace {

namespace fs = std::filesystem;

struct GraphArgs {
  std::string model, out;
  LoadArgs load;
};

int Graph(const GraphArgs& a) {
  const std::string& path = a.model;
  const std::string& out = a.out;
  const LoadedModel lm = Load(path, a.load);
  DiagnosticSink sink;
  const BondGraph view = CausalView(lm.graph);
  const Structure s = AnalyzeStructure(view, lm.compile.default_domain, sink);
  sink.ThrowIfErrors();
  const CausalAssignment c = AssignCausality(view, s);
  const std::string dot = MakeDot(lm.graph, &s, &c, LinkGrouping(lm));
  const fs::path outp(out);
  std::string ext = outp.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  if (outp.stem().empty() || (ext != ".dot" && ext != ".gv" && ext != ".svg" && ext != ".png"))
    throw CliExit{kExitUsage, fmt::format("the drawing's file name must end in .dot, .gv, .svg or .png (got '{}')", out)};
  const fs::path dot_path = ext == ".dot" || ext == ".gv" ? outp : fs::path(outp).replace_extension(".dot");
  RefuseWritingOnto({dot_path, outp}, {path});
  if (dot_path.has_parent_path()) {
    std::error_code ec;
    fs::create_directories(dot_path.parent_path(), ec);
    if (ec)  // e.g. a path through a file: afile/g.dot
      throw CliExit{kExitIo, fmt::format("cannot write '{}': cannot create the folder '{}' ({})", out,
                                         dot_path.parent_path().string(), ec.message())};
  }
  WriteFileAtomic(dot_path.string(), dot);
  std::cout << "wrote " << dot_path.string() << '\n';
  const std::vector<std::string> formats = ext == ".png" ? std::vector<std::string>{"png"} : std::vector<std::string>{"svg"};
  for (const auto& f : formats) {
    // The picture keeps the name asked for (h.SVG stays h.SVG); a .dot/.gv request gets an .svg beside it.
    const fs::path img = ext == ".dot" || ext == ".gv" ? fs::path(dot_path).replace_extension("." + f) : outp;
    std::string err;
    if (RenderWithGraphviz(dot_path.string(), img.string(), f, &err)) std::cout << "wrote " << img.string() << '\n';
    else std::cerr << "note: " << err << " (the DOT file is there; install graphviz to render it)\n";
  }
  return kExitOk;
}

}  // namespace

Command AddGraphCommand(CLI::App& app) {
  auto a = std::make_shared<GraphArgs>();
  CLI::App* cmd = app.add_subcommand("graph", "Draw the bond graph with causal strokes (Graphviz DOT, and SVG/PNG when dot is installed)");
  cmd->add_option("MODEL", a->model, "model file (YAML)")->required();
  cmd->add_option("-o,--output", a->out, "output file: .dot (or .gv), .svg or .png; an image gets its .dot source next to it")
      ->required()
      ->check(kPathName);
  AddLoadOptions(cmd, a->load);
  return {cmd, [a](const std::vector<std::string>&) { return Graph(*a); }, [] { return true; }};
}

}  // namespace multibond::cli
