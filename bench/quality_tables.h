// The quality benchmark's Markdown tables: the inputs, every row of one mesh in one noise case,
// and the summary of one noise case over the meshes (docs/quality-method.md says how to read
// them).
#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "bench/quality_inputs.h"
#include "bench/quality_runs.h"

namespace meshsmooth::bench {

// Appends the Inputs row of `s`, measured with `seeds` seeds; `eval_seconds` is one evaluation
// on one thread.
void InputsRow(std::string& out, const Subject& s, int seeds, double eval_seconds);

// Appends the Inputs row of an input that could not be loaded.
void SkippedInputRow(std::string& out, const std::string& name, const absl::Status& status);

// Appends the Inputs section: its heading, the table's header and `rows`.
void InputsTable(std::string& out, const std::string& rows);

// Appends the table of every row of `mc` in the case named `case_name`, measured with `seeds`
// seeds.
void DetailTable(std::string& out, const std::string& case_name, const MeshCase& mc, int seeds);

// Appends the summary of case `c` over `meshes` (their rows are `jobs`): the input, the default
// job, the best oracle row and the targets the default job misses.
void SummaryTable(std::string& out, const Case& c, const std::vector<MeshCase>& meshes, const std::vector<Job>& jobs);

}  // namespace meshsmooth::bench
