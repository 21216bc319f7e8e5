// perifx Python module (pybind11): build worlds from scene files or dicts, step them, read every
// registered field as a read-only NumPy view, and run scenes to files as `perifx run` does.
//
// Array lifetime: field(), positions() and velocities() return views of the world's own memory, not
// copies. Each view holds a reference to its World (the world lives at least as long as the view),
// and is valid until the world steps or restores a checkpoint: then take new views (or copy with
// numpy.array(view) to keep values). Surfaces and pieces are copied (they are computed on request).
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <optional>
#include <string>

#include "perifx/world.hpp"
#include "runner.hpp"

namespace py = pybind11;
using perifx::World;

namespace {

py::dtype dtype_of(perifx::FieldType t) {
  switch (t) {
    case perifx::FieldType::f64: return py::dtype::of<double>();
    case perifx::FieldType::f32: return py::dtype::of<float>();
    case perifx::FieldType::u32: return py::dtype::of<std::uint32_t>();
    case perifx::FieldType::u16: return py::dtype::of<std::uint16_t>();
    case perifx::FieldType::u8: return py::dtype::of<std::uint8_t>();
  }
  throw std::logic_error("unknown field type");
}

// A read-only (count[, components]) array over `data`, kept alive by `owner` (the Python World).
py::array view(const py::dtype& dtype, const void* data, std::size_t count, int components, py::handle owner) {
  std::vector<py::ssize_t> shape{static_cast<py::ssize_t>(count)}, strides{dtype.itemsize() * components};
  if (components > 1) shape.push_back(components), strides.push_back(dtype.itemsize());
  py::array a(dtype, shape, strides, data, owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

py::array vec3_view(std::span<const perifx::Vec3> v, py::handle owner) {
  static_assert(sizeof(perifx::Vec3) == 3 * sizeof(double));
  return view(py::dtype::of<double>(), v.data(), v.size(), 3, owner);
}

template <class T, std::size_t N>
py::array copy_rows(const std::vector<std::array<T, N>>& rows) {
  py::array_t<T> a({static_cast<py::ssize_t>(rows.size()), static_cast<py::ssize_t>(N)});
  if (!rows.empty()) std::memcpy(a.mutable_data(), rows.data(), rows.size() * N * sizeof(T));
  return a;
}

template <class T>
py::array copy_vector(const std::vector<T>& v) {
  py::array_t<T> a(static_cast<py::ssize_t>(v.size()));
  if (!v.empty()) std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(T));
  return a;
}

py::array copy_vec3(const std::vector<perifx::Vec3>& v) {
  py::array_t<double> a({static_cast<py::ssize_t>(v.size()), py::ssize_t(3)});
  if (!v.empty()) std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(perifx::Vec3));
  return a;
}

// A scene from a path (str / os.PathLike) or a dict (dumped to JSON with Python's json module, then
// validated by the same loader as files; relative mesh paths resolve against `base`).
perifx::scene::Scene scene_of(const py::object& scene, const std::optional<std::filesystem::path>& base) {
  if (py::isinstance<py::dict>(scene)) {
    const std::string text = py::module_::import("json").attr("dumps")(scene).cast<std::string>();
    const std::filesystem::path where = (base ? *base : std::filesystem::current_path()) / "<dict>.json";
    return perifx::scene::load_scene_text(text, where);
  }
  return perifx::scene::load_scene_file(scene.cast<std::filesystem::path>());
}

}  // namespace

PYBIND11_MODULE(perifx, m) {
  m.doc() = "perifx: state-based peridynamics fracture animation of elastoplastic solids";
  m.attr("__version__") = PERIFX_VERSION;

  // perifx errors: the same one-line messages as the C++ what() and the CLI.
  static py::exception<perifx::Error> error(m, "Error");
  static py::exception<perifx::scene::SceneError> scene_error(m, "SceneError", error.ptr());
  static py::exception<perifx::geometry::GeometryError> geometry_error(m, "GeometryError", error.ptr());
  static py::exception<perifx::io::IoError> io_error(m, "IoError", error.ptr());
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const perifx::scene::SceneError& e) {
      scene_error(e.what());
    } catch (const perifx::geometry::GeometryError& e) {
      geometry_error(e.what());
    } catch (const perifx::io::IoError& e) {
      io_error(e.what());
    } catch (const perifx::Error& e) {
      error(e.what());
    }
  });

  py::class_<World>(m, "World",
                    "A simulated world. Array views (field, positions, velocities) share the world's memory: "
                    "read-only, valid until the world steps; copy with numpy.array(v) to keep them.")
      .def(py::init([](const py::object& scene, std::optional<std::filesystem::path> base, std::optional<int> threads) {
             auto sc = scene_of(scene, base);
             if (threads) sc.threads = *threads;
             return World(sc);
           }),
           py::arg("scene"), py::kw_only(), py::arg("base") = py::none(), py::arg("threads") = py::none(),
           "World(scene, *, base=None, threads=None): scene is a scene file path or a dict in the scene format "
           "(base: folder relative mesh paths in a dict resolve against; default the current directory)")
      .def("step", [](World& w, std::uint64_t n) {
             py::gil_scoped_release free;
             w.step(n);
           }, py::arg("n") = 1, "advance by n time steps")
      .def_property_readonly("time", &World::time)
      .def_property_readonly("dt", &World::dt)
      .def_property_readonly("step_count", &World::step_count)
      .def_property_readonly("particle_count", &World::particle_count)
      .def_property_readonly("bond_count", &World::bond_count, "directed bonds (each pair counts twice)")
      .def_property_readonly("alive_bond_count", &World::alive_bond_count)
      .def_property_readonly("fragment_count", &World::fragment_count, "pieces: connected components of alive bonds")
      .def_property_readonly("first_break_time", &World::first_break_time,
                             "s: end of the step in which a bond first broke (initial cracks do not count); None before")
      .def_property_readonly("threads", &World::threads)
      .def_property_readonly("name", [](const World& w) { return w.scene().name; })
      .def("stable_time_step", &World::stable_time_step)
      .def("contact_time_scale", &World::contact_time_scale)
      .def("field_names", &World::field_names)
      .def("field", [](py::object self, const std::string& name) {
             const World& w = self.cast<const World&>();
             perifx::FieldView f;
             try {
               f = w.field(name);
             } catch (const std::out_of_range& e) {
               throw py::key_error(e.what());
             }
             return view(dtype_of(f.type), f.data, f.count, f.components, self);
           }, py::arg("name"), "a registered field as a read-only NumPy view (count,) or (count, 3)")
      .def("fields", [](py::object self) {
             py::dict out;
             for (const auto& name : self.cast<const World&>().field_names())
               out[py::str(name)] = self.attr("field")(name);
             return out;
           }, "every registered field by name")
      .def("positions", [](py::object self) { return vec3_view(self.cast<const World&>().positions(), self); })
      .def("reference_positions", [](py::object self) { return vec3_view(self.cast<const World&>().reference_positions(), self); })
      .def("velocities", [](py::object self) { return vec3_view(self.cast<const World&>().velocities(), self); })
      .def("pieces", [](const World& w) {
             const perifx::FieldView f = w.field("fragment_id");
             const auto* ids = static_cast<const std::uint32_t*>(f.data);
             return copy_vector(std::vector<std::uint32_t>(ids, ids + f.count));
           }, "per particle: its piece (fragment) id, the smallest particle index of its connected component")
      .def("surface", [](const World& w) {
             const perifx::SurfaceMesh s = w.surface();
             py::dict d;
             d["vertices"] = copy_vec3(s.vertices);
             d["triangles"] = copy_rows(s.triangles);
             d["crack"] = copy_vector(s.crack);
             d["fragment"] = copy_vector(s.fragment);
             d["tet"] = copy_vector(s.tet);
             return d;
           }, "the split embedded mesh's boundary: dict of vertices (V,3), triangles (T,3), crack (T,), "
              "fragment (T,), tet (T,); copies")
      .def("diagnostics", [](const World& w) {
             const auto d = w.diagnostics();
             py::dict out;
             out["kinetic_energy"] = d.kinetic_energy;
             out["elastic_energy"] = d.elastic_energy;
             out["gravity_energy"] = d.gravity_energy;
             return out;
           })
      .def("memory_bytes", [](const World& w) { return w.memory().total_bytes; })
      .def("memory", [](const World& w) {
             const auto use = w.memory();
             py::dict out;
             out["particle_bytes"] = use.particle_bytes;
             out["bond_bytes"] = use.bond_bytes;
             out["mesh_bytes"] = use.mesh_bytes;
             out["contact_bytes"] = use.contact_bytes;
             out["other_bytes"] = use.other_bytes;
             out["total_bytes"] = use.total_bytes;
             return out;
           }, "bytes the world's arrays hold (their capacity), by kind: dict of particle_bytes, bond_bytes, "
              "mesh_bytes, contact_bytes, other_bytes, total_bytes")
      .def("set_profiling", &World::set_profiling, py::arg("on"),
           "time every system of the step from now on, running them one at a time (off by default)")
      .def("system_times", [](const World& w) {
             py::list out;
             for (const auto& t : w.system_times()) {
               py::dict d;
               d["system"] = t.name, d["seconds"] = t.seconds, d["steps"] = t.runs;
               out.append(d);
             }
             return out;
           }, "per system of the step, in schedule order: dict of system, seconds (wall), steps (profiled)")
      .def("save_checkpoint", [](const World& w, const std::filesystem::path& p) { w.save_checkpoint(p); }, py::arg("path"))
      .def("load_checkpoint", [](World& w, const std::filesystem::path& p) { w.load_checkpoint(p); }, py::arg("path"));

  m.def(
      "run",
      [](const py::object& scene, std::optional<std::filesystem::path> out, std::optional<std::uint64_t> frames,
         std::optional<int> threads, const py::object& progress, bool overwrite, bool resume,
         std::optional<std::filesystem::path> base, bool profile) {
        auto sc = scene_of(scene, base);
        if (threads) sc.threads = *threads;
        World world(sc);
        perifx::RunOptions opt;
        opt.output_directory = out;
        opt.frames = frames;
        opt.profile = profile;
        opt.existing = resume ? perifx::ExistingRun::resume
                       : overwrite ? perifx::ExistingRun::overwrite : perifx::ExistingRun::refuse;
        // Between frames (on this thread, which holds no GIL while stepping): Ctrl-C is seen by
        // PyErr_CheckSignals; the run then writes a checkpoint and summary.json and stops, and the
        // KeyboardInterrupt is raised when run_world returns. An exception from `progress` stops the
        // run at once.
        std::optional<py::error_already_set> interrupt;
        opt.stop_requested = [&] {
          py::gil_scoped_acquire gil;
          if (!interrupt && PyErr_CheckSignals() != 0) interrupt.emplace();
          return interrupt.has_value();
        };
        opt.on_frame = [&](const perifx::RunProgress& p) {
          if (progress.is_none() || interrupt) return;
          py::gil_scoped_acquire gil;
          py::dict d;
          d["frame"] = p.frame, d["frames"] = p.frames, d["step"] = p.step, d["steps"] = p.steps;
          d["time"] = p.time, d["steps_per_second"] = p.steps_per_second, d["eta_seconds"] = p.eta_seconds;
          d["elapsed_seconds"] = p.wall_seconds;
          progress(d);
        };
        perifx::RunSummary s;
        {
          py::gil_scoped_release free;
          s = perifx::run_world(world, opt);
        }
        if (interrupt) throw *interrupt;
        py::dict d;
        d["particles"] = s.particles, d["bonds"] = s.bonds, d["alive_bonds"] = s.alive_bonds;
        d["fragments"] = s.fragments, d["steps"] = s.steps, d["frames"] = s.frames;
        d["simulated_seconds"] = s.simulated_seconds, d["wall_seconds"] = s.wall_seconds;
        d["threads"] = s.threads, d["output_directory"] = s.output_directory;
        d["first_frame"] = s.first_frame, d["last_frame"] = s.last_frame;
        if (profile) {
          py::list prof;
          for (const auto& t : s.system_times) {
            py::dict row;
            row["system"] = t.name, row["seconds"] = t.seconds, row["steps"] = t.runs;
            prof.append(row);
          }
          d["profile"] = prof;
        }
        return d;
      },
      py::arg("scene"), py::kw_only(), py::arg("out") = py::none(), py::arg("frames") = py::none(),
      py::arg("threads") = py::none(), py::arg("progress") = py::none(), py::arg("overwrite") = false,
      py::arg("resume") = false, py::arg("base") = py::none(), py::arg("profile") = false,
      "run(scene, *, out=None, frames=None, threads=None, progress=None, overwrite=False, resume=False, "
      "profile=False): "
      "write the scene's frames as `perifx run` does; progress(dict) is called after every frame; Ctrl-C "
      "finishes the frame, writes a checkpoint and the summary, and raises KeyboardInterrupt (continue with "
      "resume=True). Returns the summary as a dict (with profile=True also 'profile': seconds per system of the "
      "step, as `perifx run --profile`).");
}
