// The paper's setting in the quality benchmark: every flow for a fixed number of iterations on
// uniform noise, on the sphere, the two-rate torus and the Stanford bunny.
#pragma once

#include <filesystem>
#include <string>

namespace meshsmooth::bench {

// Appends the section: its heading and one table per mesh, each flow run for `iterations`;
// the bunny is read from `mesh_dir` (a note replaces its table when it cannot be read).
void PaperSection(std::string& out, const std::filesystem::path& mesh_dir, int iterations);

}  // namespace meshsmooth::bench
