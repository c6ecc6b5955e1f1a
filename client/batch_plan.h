// Which files a batch of `meshsmooth smooth` reads and where each result goes: the inputs named on
// the command line and in a --batch list, folders and glob patterns expanded, each mapped to a
// path in the output folder, with the collisions refused before any file is read.
#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace meshsmooth::client {

// One file of a batch: read `input`, write `output`.
struct BatchFile {
  std::string input;   // as given, as a --batch line gave it, or FOLDER/NAME for a folder's file
  std::string output;  // OUTDIR/STEM.EXT (BatchOutputPath)
};

// True for an input that names several files: a folder, or a glob pattern (*, ? or [) that is
// not the name of an existing file.
bool NamesSeveralFiles(const std::string& input);

// True when the command line asks for a batch: several inputs, a --batch list (`list_file` not
// empty), an input naming several files (NamesSeveralFiles), or -o ending in '/'. Otherwise
// `meshsmooth smooth IN -o OUT` smooths one file into OUT (and refuses an OUT that is a folder).
bool IsBatch(const std::vector<std::string>& inputs, const std::string& list_file, const std::string& output);

// The lines of a --batch list: one input each (a file, a folder, a glob or builtin:NAME),
// surrounding blanks trimmed, empty lines and lines starting with # left out. `list_file` "-"
// reads standard input. NotFound when the file cannot be read.
absl::StatusOr<std::vector<std::string>> ReadBatchList(const std::string& list_file);

// The files of a batch, in order: the inputs, then the lines of `list_file` when not empty
// (ReadBatchList), each a file (or builtin:NAME) as it is, a folder's files with a mesh file's
// extension (.obj .ply .off .stl .drc, any case; not its subfolders) sorted by name, a glob
// pattern's matches sorted (those that are files). InvalidArgument naming the input for a folder
// without mesh files, a pattern matching none, or no input at all; ReadBatchList's errors.
absl::StatusOr<std::vector<std::string>> ExpandInputs(const std::vector<std::string>& inputs,
                                                      const std::string& list_file);

// Where a batch writes the result of `input`: `out_dir`/STEM.EXT, STEM the input's file name
// without its last extension (NAME for builtin:NAME), EXT `format` (without a dot) or, when
// `format` is empty, the input's own extension as written (ply for builtin:NAME).
std::string BatchOutputPath(const std::string& input, const std::string& out_dir, const std::string& format);

// Each input with its output path (BatchOutputPath). InvalidArgument, before any file is read,
// naming both inputs when two would write the same output (the same input given twice
// included), and naming the input when an output would be written over an input of the batch.
absl::StatusOr<std::vector<BatchFile>> PlanBatch(const std::vector<std::string>& inputs, const std::string& out_dir,
                                                 const std::string& format);

// A batch's -o: an existing folder, or made (with its parents) when missing. InvalidArgument
// when it is something other than a folder, when it is missing and its name ends in a mesh
// file's extension (a single output's name given to a batch), or when it cannot be made or
// written into.
absl::Status PrepareOutputFolder(const std::string& out_dir);

}  // namespace meshsmooth::client
