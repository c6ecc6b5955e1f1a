#include "client/batch_plan.h"

#include <glob.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "core/io/mesh_io.h"

namespace meshsmooth::client {
namespace {

namespace fs = std::filesystem;

constexpr absl::string_view kBuiltin = "builtin:";

bool IsBuiltin(const std::string& input) { return absl::StartsWith(input, kBuiltin); }

bool HasGlobCharacters(const std::string& input) { return input.find_first_of("*?[") != std::string::npos; }

// A path as one key however it was spelt (./a.ply, dir/../a.ply, a symbolic link to it).
std::string PathKey(const std::string& path) {
  std::error_code error;
  fs::path canonical = fs::weakly_canonical(fs::absolute(path), error);
  if (error) canonical = fs::absolute(path).lexically_normal();
  return canonical.string();
}

// A folder's files with a mesh file's extension, sorted by name.
absl::StatusOr<std::vector<std::string>> FolderFiles(const std::string& folder) {
  std::vector<std::string> files;
  std::error_code error;
  for (const fs::directory_entry& e : fs::directory_iterator(folder, error)) {
    if (e.is_regular_file(error) && FormatFromPath(e.path().filename().string()).ok()) {
      files.push_back(e.path().string());
    }
  }
  if (error) return absl::InvalidArgumentError(absl::StrCat(folder, ": ", error.message()));
  if (files.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("the folder ", folder, " holds no mesh file (.obj .ply .off .stl .drc)"));
  }
  std::sort(files.begin(), files.end());
  return files;
}

// The files a glob pattern matches, sorted (glob's own order).
absl::StatusOr<std::vector<std::string>> GlobFiles(const std::string& pattern) {
  glob_t matches{};
  const int rc = glob(pattern.c_str(), 0, nullptr, &matches);
  std::vector<std::string> files;
  for (size_t i = 0; rc == 0 && i < matches.gl_pathc; ++i) {
    std::error_code error;
    if (fs::is_regular_file(matches.gl_pathv[i], error)) files.emplace_back(matches.gl_pathv[i]);
  }
  globfree(&matches);
  if (files.empty()) return absl::InvalidArgumentError(absl::StrCat("the pattern ", pattern, " matches no file"));
  return files;
}

absl::Status AppendExpanded(const std::string& input, std::vector<std::string>& out) {
  std::error_code error;
  absl::StatusOr<std::vector<std::string>> files;
  if (!IsBuiltin(input) && fs::is_directory(input, error)) {
    files = FolderFiles(input);
  } else if (NamesSeveralFiles(input)) {
    files = GlobFiles(input);
  } else {
    out.push_back(input);
    return absl::OkStatus();
  }
  if (!files.ok()) return files.status();
  out.insert(out.end(), files->begin(), files->end());
  return absl::OkStatus();
}

}  // namespace

bool NamesSeveralFiles(const std::string& input) {
  if (IsBuiltin(input)) return false;
  std::error_code error;
  if (fs::is_directory(input, error)) return true;
  return HasGlobCharacters(input) && !fs::exists(input, error);
}

bool IsBatch(const std::vector<std::string>& inputs, const std::string& list_file, const std::string& output) {
  if (inputs.size() > 1 || !list_file.empty()) return true;
  return std::any_of(inputs.begin(), inputs.end(), NamesSeveralFiles) || absl::EndsWith(output, "/");
}

absl::StatusOr<std::vector<std::string>> ReadBatchList(const std::string& list_file) {
  std::ifstream file;
  if (list_file != "-") {
    file.open(list_file);
    if (!file) return absl::NotFoundError(absl::StrCat("--batch ", list_file, ": cannot be read"));
  }
  std::istream& in = list_file == "-" ? std::cin : file;
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line)) {
    const absl::string_view entry = absl::StripAsciiWhitespace(line);
    if (entry.empty() || absl::StartsWith(entry, "#")) continue;
    lines.emplace_back(entry);
  }
  return lines;
}

absl::StatusOr<std::vector<std::string>> ExpandInputs(const std::vector<std::string>& inputs,
                                                      const std::string& list_file) {
  std::vector<std::string> named = inputs;
  if (!list_file.empty()) {
    absl::StatusOr<std::vector<std::string>> lines = ReadBatchList(list_file);
    if (!lines.ok()) return lines.status();
    named.insert(named.end(), lines->begin(), lines->end());
  }
  std::vector<std::string> files;
  for (const std::string& input : named) {
    if (absl::Status s = AppendExpanded(input, files); !s.ok()) return s;
  }
  if (files.empty()) return absl::InvalidArgumentError("no input: give files, folders, glob patterns or --batch FILE");
  return files;
}

std::string BatchOutputPath(const std::string& input, const std::string& out_dir, const std::string& format) {
  std::string stem, extension;
  if (IsBuiltin(input)) {
    stem = input.substr(kBuiltin.size());
    extension = "ply";
  } else {
    const fs::path name = fs::path(input).filename();
    stem = name.stem().string();
    extension = std::string(absl::StripPrefix(name.extension().string(), "."));
  }
  if (!format.empty()) extension = format;
  return (fs::path(out_dir) / (extension.empty() ? stem : absl::StrCat(stem, ".", extension))).string();
}

absl::StatusOr<std::vector<BatchFile>> PlanBatch(const std::vector<std::string>& inputs, const std::string& out_dir,
                                                 const std::string& format) {
  std::map<std::string, const std::string*> input_keys;  // an input's path -> the input
  for (const std::string& input : inputs) {
    if (!IsBuiltin(input)) input_keys.emplace(PathKey(input), &input);
  }
  std::map<std::string, const std::string*> writers;  // an output's path -> the input writing it
  std::vector<BatchFile> files;
  for (const std::string& input : inputs) {
    BatchFile f{input, BatchOutputPath(input, out_dir, format)};
    const std::string key = PathKey(f.output);
    if (auto it = input_keys.find(key); it != input_keys.end()) {
      return absl::InvalidArgumentError(absl::StrCat("the result of ", input, " would be written over the input ",
                                                     *it->second, " (", f.output, "): give another -o folder"));
    }
    if (auto [it, added] = writers.emplace(key, &input); !added) {
      return absl::InvalidArgumentError(absl::StrCat(*it->second, " and ", input, " would both be written to ",
                                                     f.output, ": rename one, or smooth them in separate runs"));
    }
    files.push_back(std::move(f));
  }
  return files;
}

absl::Status PrepareOutputFolder(const std::string& out_dir) {
  std::error_code error;
  if (fs::exists(out_dir, error) && !fs::is_directory(out_dir, error)) {
    return absl::InvalidArgumentError(
        absl::StrCat("-o ", out_dir, ": not a folder; a batch writes its results into a folder"));
  }
  if (!fs::exists(out_dir, error)) {
    if (!absl::EndsWith(out_dir, "/") && FormatFromPath(out_dir).ok()) {
      return absl::InvalidArgumentError(absl::StrCat("-o ", out_dir,
                                                     ": a batch writes its results into a folder, and this names a "
                                                     "mesh file; give a folder (it is made when missing)"));
    }
    fs::create_directories(out_dir, error);
    if (error) return absl::InvalidArgumentError(absl::StrCat("-o ", out_dir, ": ", error.message()));
  }
  if (access(out_dir.c_str(), W_OK) != 0) {
    return absl::InvalidArgumentError(absl::StrCat("-o ", out_dir, ": the folder is not writable"));
  }
  return absl::OkStatus();
}

}  // namespace meshsmooth::client
