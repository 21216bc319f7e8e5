// Everything `perifx run` would refuse before the first step, without building the world's bonds:
// every body's mesh is read, placed and checked as setup does (placed_mesh), and the peak memory of
// the world is estimated from the particle count and the bonds a horizon sphere holds. `perifx check`
// runs it (then builds the world for the stable-step limit); `perifx run` runs it unless --force.
#pragma once
#include <cstddef>
#include <string>

#include "perifx/errors.hpp"
#include "perifx/scene.hpp"

namespace perifx::setup {

// Measured figures (World::memory on the shipped scenes, tests/engine/test_world.cpp): per directed
// bond 5 B (neighbour, alive flag), 8 B more when some material can yield (e^p and its mirror, float),
// 4 B more when a weak plane cuts bonds, 1 bit more in the contact list when particle contact is on
// (bytes_per_bond); 377–518 B per particle (the most with a collider's surface frames: fig16 full),
// 337–348 B more in the contact grids and pair list when contact is on (240–251 B until the update's
// search grid, 328–339 B until the displaced grid, both 2026-12-07: fig16 and fig01 previews); the tet mesh and the embedded
// mesh 393 B per tet (fig01 preview, fig16 full). Setup holds transient arrays on top (adjacency, Morton
// keys, the one-sided bond check's cursors; the family lists were one until they became the bond
// array itself), hence the peak factor: the full bunny's peak RSS in one process is 1.09 GiB
// (1.167 GB on 1 and on 2 threads, with release_freed_memory_promptly below) against 1003 MiB of arrays
// and an estimate of 1.15 GiB (test `preflight: …` holds the estimate above what the world holds).
// The same factor covers what a shattering run adds once set-up's transients are gone: the contact rows
// keep room to grow (row_capacity in systems/contact.cpp) and crack faces split the embedded mesh. Grown
// arrays at the end of each preview (World::memory, 2026-12-07): fig01 brittle, the most shattered
// (2,447 pieces of 9,600 particles), +23 % (contact +229 B and mesh +149 B per particle), where the
// estimate is 1.31× what the world then holds; the bunny +3.8 %, fig15 +3.9 %, fig17 +2.3 %, the
// showcase +2.8 %. The test steps mpi_impact.json to its end and checks it again.
inline constexpr double kBytesPerBondState = 5.0;
inline constexpr double kBytesPerBondPlastic = 8.0;
inline constexpr double kBytesPerBondScale = 4.0;
inline constexpr double kBytesPerBondContact = 0.125;
inline constexpr double kBytesPerParticle = 520.0;
inline constexpr double kBytesPerParticleContact = 350.0;
inline constexpr double kBytesPerTet = 400.0;
inline constexpr double kPeakFactor = 1.25;

// A distributed run's ranks on this machine (perifx run under mpirun): rank 0 builds the whole world,
// keeps it for output and makes every other rank's part; the other ranks hold their part only
// (World::split). Measured on the full bunny (bench/README.md, "Set-up on rank 0 only"; single-process
// peak W = 1.09 GiB, 1 thread per rank, 2026-12-06): a rank other than 0 peaked at 1.09 × W/N at 2 ranks
// and 1.43–1.96 × W/N at 4 (the ghosts' share grows with N), rank 0 at W + 0.89 × W/N at 2 ranks and
// W + 0.81 × W/N at 4. So a part is taken as kPartPeakFactor × W/N, and rank 0 as W plus one part.
struct RankPlacement {
  int ranks = 1;             // in the job
  int local_ranks = 1;       // on this machine, sharing its memory
  bool holds_rank0 = true;   // rank 0 is one of them
};
inline constexpr double kPartPeakFactor = 2.0;
// This machine's estimated peak for a whole world of `world_bytes` (one process: world_bytes).
double machine_bytes(double world_bytes, const RankPlacement& placement);
// The threads rank `rank` sets its world up with when each rank steps on `threads` (> 0): rank 0 builds
// the whole world and checks its time step while the other ranks on its machine wait for it asleep
// (distributed::broadcast_bytes with Wait::asleep), so it takes their threads too, up to what this
// process may run on (oneTBB's default concurrency: the cores of its affinity mask). `threads` otherwise.
int setup_threads(int threads, int rank, const RankPlacement& placement);

struct MemoryEstimate {
  std::size_t particles = 0;
  double bonds = 0.0;            // directed bonds, estimated
  double world_bytes = 0.0;      // the whole world's estimated peak in one process, with kPeakFactor
  double bytes = 0.0;            // this machine's estimated peak (machine_bytes; world_bytes in one process)
  int ranks = 1, local_ranks = 1;  // the placement it was made for
  double available = -1.0;       // MemAvailable from /proc/meminfo, bytes; < 0 when unknown
  bool meshed = false;           // false: refused from the primitives' cell counts, before meshing
};

// Not enough memory for a scene: what() is the one-line "<scene>: /bodies: ..." message.
class MemoryError : public Error {
 public:
  using Error::Error;
};

// Estimates the peak memory of `scene` on this machine (meshing every body; primitives whose cell
// count alone is beyond the available memory are refused before meshing), for one process or for the
// ranks `placement` puts here. Throws SceneError for a bad mesh and, when `enforce`, MemoryError when
// the estimate exceeds the available memory.
MemoryEstimate preflight(const scene::Scene& scene, bool enforce, const RankPlacement& placement = {});

std::string format_bytes(double bytes);  // "1.2 GiB"

// Makes the C library return every freed block of 1 MiB or more to the system at once (glibc: a fixed
// M_MMAP_THRESHOLD; a no-op elsewhere). By default glibc raises that threshold up to 32 MiB after the
// first large free, and then set-up's freed mid-size arrays (the family lists, sort buffers, the
// stable-step estimate's vectors) stay in the arena of the thread that freed them: the full bunny
// (fig16 full, 5.6e5 particles) peaked at 1.27 GB on 1 thread and 1.39 GB on 2, and 1.17 GB on both
// with the threshold fixed, which is what the estimates above assume. Process-wide, so the library
// does not call it: `perifx` does at start; an embedder may.
void release_freed_memory_promptly();
// Restarts this program in place (execv of /proc/self/exe with the same arguments, so the same process
// id) with glibc's malloc backing its large blocks with transparent huge pages (the tunable
// glibc.malloc.hugetlb=1 in GLIBC_TUNABLES, read by glibc only at start). Debian's kernels give huge
// pages only to memory that asks (transparent_hugepage "madvise" mode), and the step's bond and particle
// arrays ask (systems/huge_pages.hpp), but set-up allocates hundreds of other arrays (meshes, adjacency,
// loads, the embedded mesh, contact, the estimates' vectors) that fault in 4 KiB at a time; on the VMs
// we measure on a page fault costs microseconds, and a 9e5-particle set-up took 6.1-7.6 s with them and
// 4.5-5.6 s without (bench/README.md "Set-up and malloc's huge pages"). Does nothing when: not glibc or
// not Linux; the kernel's THP mode is "never" (or unknown); GLIBC_TUNABLES already names
// glibc.malloc.hugetlb (the user's choice stands); PERIFX_HUGE_PAGE_MALLOC=0 (opt-out); or this is the
// restarted process (it then puts GLIBC_TUNABLES back as it was, so programs it starts, such as Blender
// or POV-Ray, see the caller's environment). If execv fails the program goes on as it is.
// Process-wide, so the library does not call it: `perifx` and `perifx_bench` do first thing in main;
// an embedder may set the tunable itself (python/README.md).
void restart_with_huge_page_malloc(char** argv);
// This process's resident memory and the part of it in transparent huge pages (anonymous), bytes, from
// /proc/self/smaps_rollup; both < 0 when unknown (not Linux).
struct ResidentMemory {
  double total = -1.0, huge_pages = -1.0;
};
ResidentMemory resident_memory();
// Bytes per directed bond and per particle the world will hold for this scene (see the figures above).
double bytes_per_bond(const scene::Scene& scene);
double bytes_per_particle(const scene::Scene& scene);

}  // namespace perifx::setup
