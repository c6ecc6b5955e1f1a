// meshsmooth._core: the Python package's way into the client library. One function, smooth(),
// runs a job as the CLI runs it (client/job_run.h): in this process on the mesh in memory, or
// through a meshsmoothd with the Draco codec both ways. meshsmooth/__init__.py wraps it in the
// typed public API.
//
// The job runs on a thread of its own while the calling thread waits with the GIL released,
// woken by the job's progress (handed to the Python callback, with the GIL, on the calling
// thread) and every kSignalPoll, to let Python run its signal handlers: Ctrl-C raises
// KeyboardInterrupt there, which cancels the job (on the server too) before it propagates.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <limits>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "client/connection.h"
#include "client/job_options.h"
#include "client/job_run.h"
#include "client/transfer.h"
#include "core/attributes.h"
#include "core/mesh.h"
#include "google/protobuf/descriptor.h"
#include "google/protobuf/message.h"

namespace py = pybind11;

namespace meshsmooth::python {
namespace {

using client::ConnectionOptions;
using client::SmoothOptions;

// How often the waiting thread looks for Python's signals (Ctrl-C) while no progress comes.
constexpr std::chrono::milliseconds kSignalPoll{50};

// A failed job's status; raised in Python as _core.StatusError(code name, message).
struct StatusError {
  absl::Status status;
};

[[noreturn]] void Fail(absl::Status status) { throw StatusError{std::move(status)}; }

// One field of a protobuf message (or one element of a repeated field) as a Python value.
py::object FieldValue(const google::protobuf::Message& m, const google::protobuf::FieldDescriptor* f, int index);

// A protobuf message as a dict of every field by its proto name: numbers, strings, enum value
// names, lists for repeated fields, dicts for messages (None for one that is not set).
py::dict ToDict(const google::protobuf::Message& m) {
  py::dict out;
  const google::protobuf::Descriptor* d = m.GetDescriptor();
  const google::protobuf::Reflection* r = m.GetReflection();
  for (int i = 0; i < d->field_count(); ++i) {
    const google::protobuf::FieldDescriptor* f = d->field(i);
    if (f->is_repeated()) {
      py::list values;
      for (int k = 0; k < r->FieldSize(m, f); ++k) values.append(FieldValue(m, f, k));
      out[py::str(f->name())] = values;
    } else if (f->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_MESSAGE && !r->HasField(m, f)) {
      out[py::str(f->name())] = py::none();
    } else {
      out[py::str(f->name())] = FieldValue(m, f, -1);
    }
  }
  return out;
}

py::object FieldValue(const google::protobuf::Message& m, const google::protobuf::FieldDescriptor* f, int index) {
  using FD = google::protobuf::FieldDescriptor;
  const google::protobuf::Reflection* r = m.GetReflection();
  const bool rep = index >= 0;
  switch (f->cpp_type()) {
    case FD::CPPTYPE_INT32:
      return py::int_(rep ? r->GetRepeatedInt32(m, f, index) : r->GetInt32(m, f));
    case FD::CPPTYPE_INT64:
      return py::int_(rep ? r->GetRepeatedInt64(m, f, index) : r->GetInt64(m, f));
    case FD::CPPTYPE_UINT32:
      return py::int_(rep ? r->GetRepeatedUInt32(m, f, index) : r->GetUInt32(m, f));
    case FD::CPPTYPE_UINT64:
      return py::int_(rep ? r->GetRepeatedUInt64(m, f, index) : r->GetUInt64(m, f));
    case FD::CPPTYPE_DOUBLE:
      return py::float_(rep ? r->GetRepeatedDouble(m, f, index) : r->GetDouble(m, f));
    case FD::CPPTYPE_FLOAT:
      return py::float_(rep ? r->GetRepeatedFloat(m, f, index) : r->GetFloat(m, f));
    case FD::CPPTYPE_BOOL:
      return py::bool_(rep ? r->GetRepeatedBool(m, f, index) : r->GetBool(m, f));
    case FD::CPPTYPE_ENUM:
      return py::str((rep ? r->GetRepeatedEnum(m, f, index) : r->GetEnum(m, f))->name());
    case FD::CPPTYPE_STRING:
      return py::str(rep ? r->GetRepeatedString(m, f, index) : r->GetString(m, f));
    case FD::CPPTYPE_MESSAGE:
      return ToDict(rep ? r->GetRepeatedMessage(m, f, index) : r->GetMessage(m, f));
  }
  return py::none();
}

const char* TypeName(const std::string&) { return "a string"; }
const char* TypeName(double) { return "a number"; }
const char* TypeName(long long) { return "a whole number"; }
const char* TypeName(int) { return "a whole number"; }
const char* TypeName(bool) { return "True or False"; }

// params[key] into `field` when given and not None; InvalidArgument naming it for a value of
// another type.
template <typename T>
void Take(const py::dict& params, const char* key, T& field) {
  if (!params.contains(key) || params[key].is_none()) return;
  const py::object value = params[key];
  try {
    field = value.cast<T>();
  } catch (const py::cast_error&) {
    Fail(absl::InvalidArgumentError(
        absl::StrCat(key, " must be ", TypeName(field), ", got ", std::string(py::repr(value)))));
  }
}

// An unsigned parameter: InvalidArgument naming it for a negative number.
void TakeCount(const py::dict& params, const char* key, unsigned& field) {
  long long value = field;
  Take(params, key, value);
  if (value < 0 || value > std::numeric_limits<unsigned>::max()) {
    Fail(absl::InvalidArgumentError(absl::StrCat(key, " must be a whole number >= 0, got ", value)));
  }
  field = static_cast<unsigned>(value);
}

// The job's keyword parameters, named as SmoothOptions names them (the CLI's flags).
SmoothOptions OptionsFrom(const py::dict& params) {
  SmoothOptions o;
  o.flow = "auto";
  Take(params, "flow", o.flow);
  TakeCount(params, "iterations", o.iterations);
  Take(params, "step", o.step);
  Take(params, "weights", o.weights);
  Take(params, "mu", o.mu);
  Take(params, "pass_band", o.pass_band);
  Take(params, "tangential_weight", o.tangential_weight);
  Take(params, "epsilon", o.epsilon);
  TakeCount(params, "normal_iterations", o.normal_iterations);
  TakeCount(params, "vertex_iterations", o.vertex_iterations);
  Take(params, "sigma_spatial", o.sigma_spatial);
  Take(params, "sigma_range", o.sigma_range);
  Take(params, "adaptive", o.adaptive);
  Take(params, "threshold", o.threshold);
  TakeCount(params, "recompute_every", o.recompute_every);
  Take(params, "boundary", o.boundary);
  Take(params, "tolerance", o.tolerance);
  Take(params, "ridges", o.ridges);
  Take(params, "ridge_threshold", o.ridge_threshold);
  Take(params, "job_id", o.job_id);
  Take(params, "max_displacement", o.max_displacement);
  Take(params, "enhance", o.enhance);
  Take(params, "gain", o.gain);
  Take(params, "detail", o.detail);
  Take(params, "smooth_first", o.smooth_first);
  Take(params, "method", o.method);
  if (absl::Status s = client::CheckSmoothOptions(o); !s.ok()) Fail(s);
  return o;
}

ConnectionOptions ConnectionFrom(const py::dict& connection) {
  ConnectionOptions c;
  Take(connection, "server", c.server);
  Take(connection, "token_file", c.token_file);
  Take(connection, "tls_ca", c.tls_ca);
  Take(connection, "timeout", c.timeout_seconds);
  Take(connection, "retries", c.retries);
  if (!(c.timeout_seconds > 0.0 && c.timeout_seconds <= 1e9)) {
    Fail(absl::InvalidArgumentError(
        absl::StrCat("timeout must be seconds above 0 (at most 1e9), got ", c.timeout_seconds)));
  }
  if (c.retries < 0 || c.retries > 100) {
    Fail(absl::InvalidArgumentError(absl::StrCat("retries must be in 0..100, got ", c.retries)));
  }
  if (!c.server.empty()) {
    if (absl::Status s = client::ChannelTarget(c.server).status(); !s.ok()) Fail(s);
  }
  return c;
}

using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;

// An (N, `columns`) array's rows: InvalidArgument naming it for another shape.
void CheckRows(const py::array& a, const char* name, py::ssize_t columns, py::ssize_t rows = -1) {
  const bool shaped = a.ndim() == 2 && a.shape(1) == columns && (rows < 0 || a.shape(0) == rows);
  if (shaped) return;
  std::string shape;
  for (py::ssize_t i = 0; i < a.ndim(); ++i) absl::StrAppend(&shape, i > 0 ? ", " : "", a.shape(i));
  Fail(absl::InvalidArgumentError(absl::StrCat(name, ": an array of shape (", rows < 0 ? "N" : std::to_string(rows),
                                               ", ", columns, ") is needed, got (", shape, ")")));
}

// The mesh the arrays hold: positions in double, faces as int32, per-vertex normals (their
// layout says where the fresh ones go; FreshNormals).
Mesh MeshFrom(const Doubles& vertices, const py::array_t<int64_t, py::array::c_style | py::array::forcecast>& faces,
              const py::object& normals) {
  CheckRows(vertices, "vertices", 3);
  CheckRows(faces, "faces", 3);
  Mesh mesh;
  const auto v = vertices.unchecked<2>();
  mesh.positions.resize(v.shape(0));
  for (py::ssize_t i = 0; i < v.shape(0); ++i) mesh.positions[i] = {v(i, 0), v(i, 1), v(i, 2)};
  const auto f = faces.unchecked<2>();
  mesh.triangles.resize(f.shape(0));
  for (py::ssize_t t = 0; t < f.shape(0); ++t) {
    for (int k = 0; k < 3; ++k) {
      const int64_t index = f(t, k);
      if (index < std::numeric_limits<int32_t>::min() || index > std::numeric_limits<int32_t>::max()) {
        Fail(absl::InvalidArgumentError(absl::StrCat("faces: index ", index, " of face ", t, " is not an int32")));
      }
      mesh.triangles[t][k] = static_cast<int32_t>(index);
    }
  }
  if (!normals.is_none()) {
    const Doubles n = normals.cast<Doubles>();
    CheckRows(n, "attributes['normals']", 3, v.shape(0));
    mesh.normals.components = 3;
    mesh.normals.values.assign(n.data(), n.data() + n.size());
    mesh.normals.corners.reserve(3 * mesh.triangles.size());
    for (const Triangle& t : mesh.triangles)
      mesh.normals.corners.insert(mesh.normals.corners.end(), t.begin(), t.end());
  }
  return mesh;
}

std::vector<float> StrengthFrom(const py::object& strength) {
  if (strength.is_none()) return {};
  const auto s = strength.cast<py::array_t<float, py::array::c_style | py::array::forcecast>>();
  if (s.ndim() != 1) Fail(absl::InvalidArgumentError("strength: a one-dimensional array, one value per vertex"));
  return std::vector<float>(s.data(), s.data() + s.size());
}

// One job on a thread of its own (see the top of the file).
class Job {
 public:
  Job(SmoothOptions options, ConnectionOptions connection, Mesh mesh, std::vector<float> strength)
      : options_(std::move(options)),
        connection_(std::move(connection)),
        mesh_(std::move(mesh)),
        strength_(std::move(strength)) {}

  // Starts the job and waits for its end; `on_progress` (None or a callable taking the
  // Progress as a dict) runs on this thread. A Python exception on this thread (Ctrl-C, the
  // callback's own) cancels the job and is raised once the job has ended.
  void Run(const py::object& on_progress) {
    thread_ = std::thread([this] { Work(); });
    try {
      WaitForEnd(on_progress);
    } catch (...) {
      cancels_.Cancel();
      Join();
      throw;
    }
    Join();
  }

  // After Run(): the job's result, or its status raised.
  py::dict Result() {
    if (!status_.ok()) Fail(status_);
    py::dict out;
    const auto n = static_cast<py::ssize_t>(mesh_.positions.size());
    py::array_t<double> vertices({n, py::ssize_t{3}});
    auto v = vertices.mutable_unchecked<2>();
    for (py::ssize_t i = 0; i < n; ++i) {
      const Vec3& p = mesh_.positions[i];
      v(i, 0) = p.x, v(i, 1) = p.y, v(i, 2) = p.z;
    }
    const auto m = static_cast<py::ssize_t>(mesh_.triangles.size());
    py::array_t<int32_t> faces({m, py::ssize_t{3}});
    auto f = faces.mutable_unchecked<2>();
    for (py::ssize_t t = 0; t < m; ++t) {
      for (int k = 0; k < 3; ++k) f(t, k) = mesh_.triangles[t][k];
    }
    out["vertices"] = vertices;
    out["faces"] = faces;
    if (!mesh_.normals.empty()) {
      const std::optional<std::vector<double>> normals = PerVertexValues(mesh_, mesh_.normals);
      // Zeros for a vertex no face names (PerVertexValues); every vertex has one entry here.
      py::array_t<double> array({n, py::ssize_t{3}});
      std::fill_n(array.mutable_data(), 3 * n, 0.0);
      if (normals.has_value()) std::copy(normals->begin(), normals->end(), array.mutable_data());
      out["normals"] = array;
    }
    if (options_.ridges) out["ridge_labels"] = py::array_t<uint8_t>(labels_.size(), labels_.data());
    out["summary"] = ToDict(summary_);
    out["warnings"] = warnings_;
    return out;
  }

 private:
  void WaitForEnd(const py::object& on_progress) {
    for (;;) {
      std::optional<v1::Progress> progress;
      bool done = false;
      {
        py::gil_scoped_release release;
        std::unique_lock<std::mutex> lock(mu_);
        cv_.wait_for(lock, kSignalPoll, [this] { return done_ || pending_.has_value(); });
        progress = std::exchange(pending_, std::nullopt);
        done = done_;
      }
      if (progress.has_value() && !on_progress.is_none()) on_progress(ToDict(*progress));
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      if (done) return;
    }
  }

  void Join() {
    py::gil_scoped_release release;
    if (thread_.joinable()) thread_.join();
  }

  // On the job's thread: no Python object is touched here.
  void Work() {
    status_ = RunJob();
    std::lock_guard<std::mutex> lock(mu_);
    done_ = true;
    cv_.notify_all();
  }

  absl::Status RunJob() {
    const bool in_memory = connection_.server.empty();
    absl::StatusOr<client::Upload> upload = client::UploadMesh(std::move(mesh_), std::move(strength_), in_memory);
    if (!upload.ok()) return upload.status();
    warnings_ = upload->warnings;
    const v1::JobSpec spec = client::SpecFrom(options_, upload->strength);
    client::JobHooks hooks;
    // Only the newest progress waits for the calling thread.
    hooks.progress = [this](const v1::Progress& p) {
      std::lock_guard<std::mutex> lock(mu_);
      pending_ = p;
      cv_.notify_all();
    };
    client::JobRun run;
    if (in_memory) {
      run = client::RunInMemory(spec, *upload, connection_, cancels_, hooks);
    } else {
      client::ServiceLink service(connection_);
      run = client::RunThroughService(spec, *upload, service, cancels_, hooks);
    }
    if (!run.status.ok()) return run.status;
    summary_ = std::move(run.summary);
    for (const std::string& w : summary_.warnings()) warnings_.push_back(w);
    std::vector<Vec3> points = std::move(run.local.points);
    labels_ = std::move(run.local.labels);
    if (!in_memory) {
      absl::StatusOr<client::ResultPoints> decoded = client::DecodeResultPoints(*upload, run.result, options_.ridges);
      if (!decoded.ok()) return decoded.status();
      points = std::move(decoded->points);
      labels_ = std::move(decoded->labels);
    }
    absl::StatusOr<Mesh> mesh = client::ResultMesh(*upload, std::move(points));
    if (!mesh.ok()) return mesh.status();
    mesh_ = *std::move(mesh);
    return absl::OkStatus();
  }

  const SmoothOptions options_;
  const ConnectionOptions connection_;
  Mesh mesh_;  // the input, then the result
  std::vector<float> strength_;
  client::JobCancels cancels_;  // Ctrl-C on the calling thread
  std::thread thread_;
  std::mutex mu_;  // guards the two below
  std::condition_variable cv_;
  bool done_ = false;
  std::optional<v1::Progress> pending_;
  // Written by the job's thread, read after it has ended.
  absl::Status status_;
  v1::Summary summary_;
  std::vector<uint8_t> labels_;
  std::vector<std::string> warnings_;
};

py::dict Smooth(const Doubles& vertices, const py::array_t<int64_t, py::array::c_style | py::array::forcecast>& faces,
                const py::dict& params, const py::dict& connection, const py::object& strength,
                const py::object& normals, const py::object& on_progress) {
  // Everything is copied out of the arrays before the GIL is let go.
  Job job(OptionsFrom(params), ConnectionFrom(connection), MeshFrom(vertices, faces, normals), StrengthFrom(strength));
  job.Run(on_progress);
  return job.Result();
}

}  // namespace
}  // namespace meshsmooth::python

PYBIND11_MODULE(_core, m) {
  using namespace meshsmooth::python;
  m.doc() = "meshsmooth's client library (C++): use the meshsmooth package's smooth(), not this";
  // Never destroyed: it would outlive the interpreter at exit.
  static auto* status_error = new py::exception<StatusError>(m, "StatusError");
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const StatusError& e) {
      const py::tuple args =
          py::make_tuple(std::string(absl::StatusCodeToString(e.status.code())), std::string(e.status.message()));
      PyErr_SetObject(status_error->ptr(), args.ptr());
    }
  });
  m.def("smooth", &Smooth, py::arg("vertices"), py::arg("faces"), py::arg("params"), py::arg("connection"),
        py::arg("strength"), py::arg("normals"), py::arg("on_progress"),
        "Runs one job; returns a dict of the result's arrays, the summary and the warnings. Raises "
        "StatusError(code, message) when the job fails.");
}
