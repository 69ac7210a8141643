#include <string_view>

#include <fmt/format.h>

#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/model_loader.h"

namespace multibond {

void ExplainInMechanismTerms(const mech::Mechanism& m, std::vector<Diagnostic>& diagnostics) {
  for (Diagnostic& d : diagnostics) {
    if (!std::string_view(d.code).starts_with("causality.") || d.details.empty()) continue;
    // The element names on the path are the quoted words of its first detail line.
    std::vector<std::string> parts;
    const std::string& path = d.details.front();
    for (size_t open = path.find('\''); open != std::string::npos;) {
      const size_t close = path.find('\'', open + 1);
      if (close == std::string::npos) break;
      std::string part = m.DescribePart(path.substr(open + 1, close - open - 1));
      if (part.empty()) part = fmt::format("'{}' (not a mechanism part)", path.substr(open + 1, close - open - 1));
      if (parts.empty() || parts.back() != part) parts.push_back(part);
      open = path.find('\'', close + 1);
    }
    bool any = false;
    for (const auto& p : parts) any = any || p.find("(not a mechanism part)") == std::string::npos;
    if (!any) continue;
    std::string line = "in mechanism terms: ";
    for (size_t i = 0; i < parts.size(); ++i) line += (i ? " -> " : "") + parts[i];
    d.details.push_back(line);
    if (d.code == codes::kCausalityDerivative)
      d.details.push_back("the last part cannot move independently of the first: the connection between them has no "
                          "compliance; connect them through a joint, gear mesh or velocity drive (they carry K and R)");
  }
}

}  // namespace multibond
