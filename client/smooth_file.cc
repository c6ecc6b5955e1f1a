#include "client/smooth_file.h"

#include <optional>
#include <utility>

#include "absl/strings/str_cat.h"
#include "client/job_options.h"
#include "client/strength.h"
#include "client/transfer.h"
#include "core/io/mesh_io.h"

namespace meshsmooth::client {
namespace {

// Without --server, a mesh file (or builtin:NAME) written to a mesh file other than .drc with
// the default lossless sequential encoding goes to a job in this process in memory. The rest goes
// through the in-process service's codec: quantization and Edgebreaker are Draco's encodings
// of the result, and a .drc or glTF input or output is Draco data itself.
bool RunsInMemory(const SmoothOptions& o, const ConnectionOptions& c, MeshFormat out) {
  if (!c.server.empty() || IsGltfPath(o.input) || IsGltfPath(o.output) || out == MeshFormat::kDraco) return false;
  const absl::StatusOr<MeshFormat> in = FormatFromPath(o.input);
  if (in.ok() && *in == MeshFormat::kDraco) return false;
  return o.quantization_bits == 0 && !o.edgebreaker;
}

FileOutcome Failed(const std::string& prefix, const absl::Status& s, FileOutcome out) {
  out.exit_code = s.code() == absl::StatusCode::kUnavailable ? kExitUnavailable : kExitFailure;
  out.error = absl::StrCat(prefix, s.message());
  return out;
}

}  // namespace

v1::Summary SummaryWithWarnings(const FileOutcome& outcome) {
  v1::Summary summary;
  for (const std::string& w : outcome.upload_warnings) summary.add_warnings(w);
  if (!outcome.upload_note.empty()) summary.add_warnings(outcome.upload_note);
  for (const std::string& d : outcome.dropped) summary.add_warnings(absl::StrCat("not kept: ", d));
  summary.MergeFrom(outcome.summary);
  return summary;
}

bool EdgebreakerFits(const std::string& input, const std::string& output) {
  // Edgebreaker orders the result's points its own way; a mesh file written from the input's own
  // connectivity (every input but a .drc) needs them in the input's order.
  const absl::StatusOr<MeshFormat> in_format = FormatFromPath(input);
  const absl::StatusOr<MeshFormat> out_format = FormatFromPath(output);
  return IsGltfPath(output) || (out_format.ok() && *out_format == MeshFormat::kDraco) ||
         (in_format.ok() && *in_format == MeshFormat::kDraco);
}

absl::Status CheckInputOutput(const SmoothOptions& o, std::vector<std::string>& warnings) {
  const bool gltf_out = IsGltfPath(o.output);
  if (!gltf_out && IsGltfPath(o.input)) {
    return absl::InvalidArgumentError(
        "a glTF scene (.glb, .gltf) is smoothed into a glTF scene: give -o FILE.glb or FILE.gltf");
  }
  absl::StatusOr<MeshFormat> out_format = gltf_out ? MeshFormat::kDraco : FormatFromPath(o.output);
  if (!out_format.ok()) return out_format.status();
  if (o.edgebreaker && !EdgebreakerFits(o.input, o.output)) {
    return absl::InvalidArgumentError(
        "--edgebreaker reorders the result's vertices; it applies to a .drc or glTF output (or a .drc input): give "
        "-o FILE.drc, or leave --edgebreaker out");
  }
  // Before the upload: a typo in the output's folder must not cost the job.
  if (absl::Status s = CheckOutputPath(o.output); !s.ok()) return s;
  if (o.ridges && (gltf_out || (*out_format != MeshFormat::kPly && *out_format != MeshFormat::kObj &&
                                *out_format != MeshFormat::kDraco))) {
    warnings.push_back(
        "--ridges labels are kept only in .ply and .obj (vertex colours) and .drc (attributes) output; the summary "
        "still counts them");
  }
  return absl::OkStatus();
}

FileOutcome SmoothFile(const SmoothOptions& o, ServiceLink& service, JobCancels& cancels, const FileHooks& hooks) {
  FileOutcome out;
  const ConnectionOptions& c = service.connection();
  const absl::StatusOr<MeshFormat> format = IsGltfPath(o.output) ? MeshFormat::kDraco : FormatFromPath(o.output);
  if (!format.ok()) return Failed("", format.status(), std::move(out));
  const bool in_memory = RunsInMemory(o, c, *format);
  // The attributes go to the service only for a .drc output, which is written as it comes back.
  absl::StatusOr<Upload> upload =
      PrepareUpload(o.input, *format == MeshFormat::kDraco, o.gltf_draco, o.strength, in_memory, o.quantize_upload);
  if (!upload.ok()) return Failed("", upload.status(), std::move(out));
  if (o.quantize_upload > 0.0) out.upload_note = DescribeUploadQuantization(upload->quantization);
  out.upload_warnings = upload->warnings;
  if (hooks.upload_warnings) hooks.upload_warnings(out.upload_warnings);
  const v1::JobSpec spec = SpecFrom(o);
  JobRun run;
  {
    std::optional<InterruptWatcher> watcher;
    if (hooks.watch_interrupt) watcher.emplace([&cancels] { cancels.Cancel(); });
    run = in_memory ? RunInMemory(spec, *upload, c, cancels, hooks)
                    : RunThroughService(spec, *upload, service, cancels, hooks);
  }
  if (hooks.job_done) hooks.job_done();
  if (run.interrupted) {
    out.exit_code = kExitInterrupted;
    out.error = "interrupted; the job was cancelled";
    return out;
  }
  if (!run.status.ok()) return Failed(run.prefix, run.status, std::move(out));
  out.dropped = upload->dropped;
  DracoOptions draco;
  draco.quantization_bits = o.quantization_bits;
  draco.method = o.edgebreaker ? DracoMethod::kEdgebreaker : DracoMethod::kSequential;
  const absl::Status written =
      in_memory
          ? WriteResultPoints(*upload, std::move(run.local.points), run.local.labels, o.output, o.ridges, &out.dropped)
          : WriteResult(*upload, run.result, o.output, o.ridges, &out.dropped, o.gltf_draco, draco);
  if (!written.ok()) return Failed("", written, std::move(out));
  out.summary = std::move(run.summary);
  return out;
}

}  // namespace meshsmooth::client
