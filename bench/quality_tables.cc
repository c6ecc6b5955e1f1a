#include "bench/quality_tables.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "core/flows/flow.h"

namespace meshsmooth::bench {
namespace {

std::string Fmt(double v, int digits) {
  if (std::isnan(v)) return "—";
  return absl::StrFormat("%.*f", digits, v);
}

// "v (v/ref ×)", v with `digits` decimals.
std::string Ratio(double v, double ref, int digits) {
  if (std::isnan(v) || !(ref > 0.0)) return Fmt(v, digits);
  return absl::StrFormat("%.*f (%.2f×)", digits, v, v / ref);
}

std::string Status(const Row& row) {
  int failed = 0, nan = 0;
  std::string first;
  for (const Run& r : row.runs) {
    if (!r.status.ok()) {
      if (failed++ == 0) first = r.status.ToString();
    } else if (r.q.non_finite_vertices > 0) {
      ++nan;
    }
  }
  std::string s = "ok";
  if (failed > 0) s = absl::StrFormat("failed on %d of %d: %s", failed, row.runs.size(), first);
  if (nan > 0) s = absl::StrCat(s, absl::StrFormat("; NaN on %d of %d", nan, row.runs.size()));
  return absl::StrReplaceAll(s, {{"|", "/"}});
}

// The iterations a row's runs made: the swept count, or what the flow ran (a range when the
// seeds differ); "—" for the noisy input.
std::string Iterations(const Row& row, bool smoothed) {
  if (!smoothed) return "—";
  if (row.iterations > 0) return absl::StrCat(row.iterations);
  int lo = kMaxIterations + 1, hi = 0;
  for (const Run& r : row.runs) {
    if (!r.status.ok()) continue;
    lo = std::min(lo, r.iterations);
    hi = std::max(hi, r.iterations);
  }
  if (hi == 0) return "—";
  return lo == hi ? absl::StrCat(lo) : absl::StrCat(lo, "–", hi);
}

// Flipped faces, and in brackets how many of them lie in fine detail (core/measure/evaluation.h).
std::string Flipped(const Quality& q) {
  return q.flipped_faces > 0 ? absl::StrCat(q.flipped_faces, " (", q.flipped_in_fine_detail, ")") : "0";
}

void DetailRow(std::string& out, const Row& row, bool smoothed) {
  double seconds = 0.0;
  int ok = 0;
  const Quality q = MeanQuality(row, &ok, &seconds);
  absl::StrAppendFormat(&out, "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", row.label,
                        Iterations(row, smoothed), Fmt(q.rms_distance, 4), Fmt(q.max_distance, 3),
                        Fmt(q.normal_error_deg, 2), Fmt(q.crease_normal_error_deg, 2), Fmt(q.volume_change_percent, 2),
                        ok > 0 ? Flipped(q) : "—", Fmt(q.edge_length_cv, 3), Fmt(q.min_angle_deg, 2),
                        smoothed && ok > 0 ? Fmt(1000.0 * seconds, 1) : "—", Status(row));
}

// The targets a default job is held to (docs/quality-method.md, "Summary tables and targets"):
// the ones `d` misses, or "none".
// The authors' BNF and GNF rows' mean normal error (NaN when a row is missing or failed).
std::pair<double, double> AnchorNormalErrors(const MeshCase& mc) {
  auto of = [&](const char* label) {
    const Row* row = FindRow(mc, label);
    return row != nullptr && AllOk(*row) ? MeanQuality(*row).normal_error_deg : std::nan("");
  };
  return {of(kBnfLabel), of(kGnfLabel)};
}

std::string MissedTargets(const Case& c, const MeshCase& mc, const Quality& noisy, const Row& def, const Quality& d,
                          const Row* best) {
  if (!AllOk(def)) return "no failure";
  std::vector<std::string> missed;
  if (c.sigma == 0.0) {
    if (!(d.rms_distance <= 0.02)) missed.push_back("RMS ≤ 0.02 h");
    if (!(d.normal_error_deg <= 2.0)) missed.push_back("normal ≤ 2°");
  } else {
    const double ratio = c.sigma >= 0.2 ? 0.6 : 0.9;
    if (!(d.rms_distance <= ratio * noisy.rms_distance)) missed.push_back(absl::StrFormat("RMS ≤ %g×", ratio));
    if (!(d.normal_error_deg <= ratio * noisy.normal_error_deg)) {
      missed.push_back(absl::StrFormat("normal ≤ %g×", ratio));
    }
    // At or below the authors' GNF under impulsive and heavy noise, below both elsewhere (NaN:
    // no anchor row, no target).
    const auto [bnf, gnf] = AnchorNormalErrors(mc);
    const bool heavy = c.noise == Noise::kImpulsive || c.sigma >= 0.5;
    if (d.normal_error_deg > gnf) missed.push_back("normal ≤ GNF");
    if (!heavy && d.normal_error_deg > bnf) missed.push_back("normal ≤ BNF");
  }
  if (std::abs(d.volume_change_percent) > 1.0) missed.push_back("volume ±1%");
  for (const Run& r : def.runs) {
    if (r.q.flipped_faces > 0) {
      missed.push_back("no flip");
      break;
    }
  }
  if (best != nullptr && !(d.rms_distance <= 1.25 * MeanQuality(*best).rms_distance)) {
    missed.push_back("≤ 1.25× best");
  }
  return missed.empty() ? "none" : absl::StrJoin(missed, ", ");
}

// The default job's iterations (mean over the seeds), its first seed's stop reason and the
// mean noise estimate.
std::string StopCell(const Row& row) {
  if (row.runs.empty() || !AllOk(row)) return "—";
  double iterations = 0.0, noise = 0.0;
  for (const Run& r : row.runs) {
    iterations += r.iterations;
    noise += r.noise_h;
  }
  const auto n = static_cast<double>(row.runs.size());
  return absl::StrFormat("%.0f, %s (%.3f)", iterations / n, row.runs[0].stop, noise / n);
}

}  // namespace

void InputsRow(std::string& out, const Subject& s, int seeds, double eval_seconds) {
  const GroundTruth& truth = *s.truth;
  const ValidationReport& r = truth.report();
  absl::StrAppendFormat(&out, "| %s | %s | %d | %d | %s | %d | %d | %d | %d | %d | %.2f / %.2f s |\n", s.name, s.what,
                        truth.mesh().num_vertices(), truth.mesh().num_triangles(), r.closed() ? "yes" : "no",
                        r.boundary_loops, truth.crease_faces(), truth.folded_faces(), truth.fine_detail_faces(), seeds,
                        s.truth_seconds, eval_seconds);
}

void SkippedInputRow(std::string& out, const std::string& name, const absl::Status& status) {
  absl::StrAppendFormat(&out, "| %s | skipped: %s | | | | | | | |\n", name, status.ToString());
}

void InputsTable(std::string& out, const std::string& rows) {
  out +=
      "\n## Inputs\n\n| mesh | source | vertices | faces | closed | boundary loops | crease faces | folded faces | "
      "fine-detail faces | seeds | ground truth / one evaluation (1 thread) |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|\n" +
      rows;
}

void DetailTable(std::string& out, const std::string& case_name, const MeshCase& mc, int seeds) {
  absl::StrAppendFormat(&out, "\n#### %s — %s (%d seed%s)\n\n", mc.mesh, case_name, seeds, seeds == 1 ? "" : "s");
  out +=
      "| row | iterations | RMS dist (h) | max dist (h) | normal err (°) | crease normal err (°) | volume (%) | "
      "flipped | edge CV | min angle (°) | time (ms) | status |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  DetailRow(out, mc.noisy, false);
  for (const Row& row : mc.rows) DetailRow(out, row, true);
}

void SummaryTable(std::string& out, const Case& c, const std::vector<MeshCase>& meshes, const std::vector<Job>& jobs) {
  absl::StrAppendFormat(&out, "\n### %s\n\n", c.Name());
  const bool clean = c.sigma == 0.0;
  const char* per = clean ? "" : ", × noisy";
  if (clean) {
    out += "| mesh | default: RMS dist (h) | normal err (°) |";
  } else {
    out += "| mesh | noisy: RMS dist (h) | normal err (°) | default: RMS dist (h, × noisy) | normal err (°, × noisy) |";
  }
  absl::StrAppendFormat(&out,
                        " default: iterations, stop (noise estimate, h) | volume (%%) | flipped | status | best oracle "
                        "| its RMS dist (h%s) | its normal err (°%s) | default / best RMS | BNF / GNF, authors' "
                        "defaults: normal err (°) | targets missed |\n",
                        per, per);
  out += clean ? "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
               : "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const MeshCase& mc : meshes) {
    const Quality noisy = MeanQuality(mc.noisy);
    const Row& def = mc.rows[0];
    const Quality d = MeanQuality(def);
    const Row* best = BestOracle(mc, jobs);
    std::vector<std::string> cells = {mc.mesh};
    if (clean) {
      cells.insert(cells.end(), {Fmt(d.rms_distance, 4), Fmt(d.normal_error_deg, 2)});
    } else {
      cells.insert(cells.end(), {Fmt(noisy.rms_distance, 3), Fmt(noisy.normal_error_deg, 2),
                                 Ratio(d.rms_distance, noisy.rms_distance, 3),
                                 Ratio(d.normal_error_deg, noisy.normal_error_deg, 2)});
    }
    cells.push_back(StopCell(def));
    cells.insert(cells.end(), {Fmt(d.volume_change_percent, 2), AllOk(def) ? Flipped(d) : "—", Status(def)});
    if (best == nullptr) {
      cells.insert(cells.end(), {"—", "—", "—", "—"});
    } else {
      const Quality b = MeanQuality(*best);
      cells.insert(
          cells.end(),
          {absl::StrFormat("%s @ %d", best->label, best->iterations),
           clean ? Fmt(b.rms_distance, 4) : Ratio(b.rms_distance, noisy.rms_distance, 3),
           clean ? Fmt(b.normal_error_deg, 2) : Ratio(b.normal_error_deg, noisy.normal_error_deg, 2),
           AllOk(def) && b.rms_distance > 0.0 ? absl::StrFormat("%.2f", d.rms_distance / b.rms_distance) : "—"});
    }
    const auto [bnf, gnf] = AnchorNormalErrors(mc);
    cells.push_back(std::isnan(bnf) && std::isnan(gnf) ? "—" : absl::StrFormat("%s / %s", Fmt(bnf, 2), Fmt(gnf, 2)));
    cells.push_back(MissedTargets(c, mc, noisy, def, d, best));
    out += "| " + absl::StrJoin(cells, " | ") + " |\n";
  }
}

}  // namespace meshsmooth::bench
