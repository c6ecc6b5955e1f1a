// meshsmooth: the command-line client.
//
// Exit codes: 0 success; 1 bad input or failed job; 2 bad command line.
#include <cstdio>
#include <iostream>
#include <string>

#include "CLI/CLI.hpp"
#include "client/inputs.h"
#include "core/metrics.h"
#include "core/topology.h"

namespace meshsmooth::cli {
namespace {

constexpr int kExitFailure = 1;

int RunInfo(const std::string& input) {
  absl::StatusOr<Mesh> mesh = LoadInput(input);
  if (!mesh.ok()) {
    std::cerr << "meshsmooth: " << mesh.status().message() << "\n";
    return kExitFailure;
  }
  ValidationReport report;
  const Topology topo = BuildTopology(*mesh, &report);
  std::cout << "# " << input << "\n\n## validation\n"
            << FormatReport(report) << "\n## metrics\n"
            << FormatMetrics(ComputeMetrics(*mesh, topo));
  return 0;
}

}  // namespace
}  // namespace meshsmooth::cli

int main(int argc, char** argv) {
  using namespace meshsmooth::cli;
  CLI::App app{"meshsmooth: smooth noisy triangle meshes while making them more regular"};
  app.require_subcommand(1);

  std::string builtin_help = "Built-in inputs (use as builtin:NAME):";
  for (const auto& [name, what] : BuiltinInputs()) builtin_help += "\n  " + name + ": " + what;
  app.footer(builtin_help);

  std::string info_input = "builtin:noisy-sphere";
  CLI::App* info = app.add_subcommand("info", "Print a mesh's validation report and metrics");
  info->add_option("input", info_input, "Mesh file (.obj .ply .off .stl .drc) or builtin:NAME")
      ->capture_default_str();

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  if (info->parsed()) return RunInfo(info_input);
  return 2;
}
