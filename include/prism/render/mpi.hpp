// prism/render/mpi.hpp — one image rendered by several processes with MPI
// (opt-in: link prism::mpi; the rest of prism never includes <mpi.h>).
//
// Every rank loads the same scene and renders a share of the work with its
// own threads: a range of sample indices of every pixel (Split::samples) or
// every size-th tile (Split::tiles). A pixel sample's random numbers depend
// only on the pixel, the sample index and the seed, so the shares add up to
// the single-process render. The root then receives the other ranks' films
// one rank after another, in rank order, and adds them in that order (not
// MPI_Reduce, whose order of summation is unspecified): the image is bitwise
// the same from run to run with the same rank count, and equal to the
// single-process image up to the order of floating-point summation.
//
// Only the thread that called init (the main thread) calls MPI; the render
// threads never do, so MPI_THREAD_FUNNELED is enough.
#pragma once
#include <mpi.h>
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <thread>
#include <vector>
#include "prism/error.hpp"
#include "prism/film/aov.hpp"
#include "prism/film/film.hpp"
#include "prism/prism.hpp"  // render.hpp and what the integrators need

namespace prism::mpi {

// How the work is cut among ranks. Samples: rank r takes sample indices
// [spp r / n, spp (r + 1) / n) of every pixel (and the matching light paths);
// every rank sees the whole image, so an expensive corner costs all ranks
// alike. Tiles: rank r takes tiles r, r + n, r + 2n, ... (and every n-th chunk
// of light paths); each pixel is rendered by one rank only.
enum class Split { samples, tiles };

inline int rank(MPI_Comm comm = MPI_COMM_WORLD) {
  int r = 0;
  MPI_Comm_rank(comm, &r);
  return r;
}
inline int size(MPI_Comm comm = MPI_COMM_WORLD) {
  int n = 1;
  MPI_Comm_size(comm, &n);
  return n;
}

// True when the process was started by an MPI launcher (mpirun, mpiexec,
// srun with PMI/PMIx): a program can then call MPI_Init, and otherwise stay a
// plain process (Open MPI's singleton start needs its runtime daemons).
inline bool launched_by_mpi() {
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "PMI_RANK", "MPI_LOCALNRANKS"})
    if (std::getenv(var)) return true;
  return false;
}

// MPI_Init_thread (funneled) and MPI_Finalize around a scope.
class Session {
 public:
  Session(int* argc, char*** argv) {
    int provided = 0;
    MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
    if (provided < MPI_THREAD_FUNNELED) {
      MPI_Finalize();
      throw Error("MPI: the library does not support threads (MPI_THREAD_FUNNELED)");
    }
  }
  ~Session() { MPI_Finalize(); }
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
};

// The ranks sharing this rank's node (MPI_COMM_TYPE_SHARED).
inline int ranks_on_node(MPI_Comm comm = MPI_COMM_WORLD) {
  MPI_Comm node;
  MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, rank(comm), MPI_INFO_NULL, &node);
  int n = size(node);
  MPI_Comm_free(&node);
  return n;
}

// Threads for this rank: as requested, or (0) the node's hardware threads
// divided among the ranks on the node, at least one. Collective.
inline int threads_per_rank(int requested, MPI_Comm comm = MPI_COMM_WORLD) {
  int local = ranks_on_node(comm);
  if (requested > 0) return requested;
  int hw = int(std::max(1u, std::thread::hardware_concurrency()));
  return std::max(1, hw / std::max(1, local));
}

// This rank's share of a whole render (opt must not be a share already).
inline RenderOptions share(const RenderOptions& opt, Split split, int r, int n) {
  if (opt.first_sample != 0 || opt.sample_count >= 0 || opt.tile_stride != 1)
    throw Error("mpi: the options are already a share of a render");
  if (n < 1 || r < 0 || r >= n) throw Error("mpi: rank " + std::to_string(r) + " is not in [0, " + std::to_string(n) + ")");
  RenderOptions o = opt;
  if (split == Split::samples) {
    int64_t spp = std::max(0, opt.spp);
    int first = int(spp * r / n), end = int(spp * (r + 1) / n);
    o.first_sample = first;
    o.sample_count = end - first;
  } else {
    o.tile_stride = n;
    o.tile_offset = r;
  }
  return o;
}

// True on every rank when ok is true on every rank. Collective: lets all
// ranks stop together (and the root report once) after a step that may fail
// on some ranks only, such as loading the scene.
inline bool all_ok(bool ok, MPI_Comm comm = MPI_COMM_WORLD) {
  int mine = ok ? 1 : 0, all = 0;
  MPI_Allreduce(&mine, &all, 1, MPI_INT, MPI_MIN, comm);
  return all == 1;
}
// The lowest rank whose ok is false (-1 when none). Collective.
inline int first_failed_rank(bool ok, MPI_Comm comm = MPI_COMM_WORLD) {
  int mine = ok ? size(comm) : rank(comm), first = 0;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, comm);
  return first == size(comm) ? -1 : first;
}

// Runs f; if it throws, prints "<program>: rank N: <message>" and aborts the
// whole job (MPI_Abort), so that no other rank waits forever for this one.
template <class F>
auto run_or_abort(const char* program, F&& f, MPI_Comm comm = MPI_COMM_WORLD) -> decltype(f()) {
  try {
    return f();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: rank %d: %s\n", program, rank(comm), e.what());
  } catch (...) {
    std::fprintf(stderr, "%s: rank %d: unknown error\n", program, rank(comm));
  }
  std::fflush(stderr);
  MPI_Abort(comm, 1);
  std::abort();  // MPI_Abort does not return
}

namespace detail {

// Waits for a request without spinning: Open MPI's blocking calls poll the
// network at full speed, which takes a core from the ranks (and threads) that
// are still rendering on the same node. Checks every 200 microseconds.
inline void wait_politely(MPI_Request& req) {
  for (;;) {
    int done = 0;
    MPI_Test(&req, &done, MPI_STATUS_IGNORE);
    if (done) return;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
}
// Waits for a transfer in progress: polls (each test moves the transfer on)
// but yields the core between polls to any other thread that wants it, such
// as the other end of the transfer on a busy node.
inline void wait_yielding(MPI_Request& req, MPI_Status* status = MPI_STATUS_IGNORE) {
  for (;;) {
    int done = 0;
    MPI_Test(&req, &done, status);
    if (done) return;
    std::this_thread::yield();
  }
}

// Pixels per message: 4 MiB of accumulators, small enough to keep the
// receive buffers small and to overlap the next message with the additions.
template <class T>
constexpr size_t chunk_elements() {
  return std::max<size_t>(1, (size_t(4) << 20) / sizeof(T));
}

// Sends n elements of data to root (non-root ranks), or receives the other
// ranks' in rank order and adds them with merge(src, first, count) (root).
// Receives are double-buffered: the next message arrives while the previous
// one is added. T is sent as bytes: all ranks run the same program.
template <class T, class Merge>
void reduce_in_rank_order(const T* data, size_t n, Merge&& merge, int root, MPI_Comm comm, int tag) {
  const int r = rank(comm), nranks = size(comm);
  const size_t chunk = chunk_elements<T>();
  const size_t messages = (n + chunk - 1) / chunk;
  if (r != root) {
    // Sleep until the root is ready for this rank (it takes them in order),
    // then send at full speed.
    int go = 0;
    MPI_Request ready;
    MPI_Irecv(&go, 1, MPI_INT, root, tag, comm, &ready);
    wait_politely(ready);
    for (size_t m = 0; m < messages; ++m) {
      size_t first = m * chunk, count = std::min(chunk, n - first);
      MPI_Request req;
      MPI_Isend(data + first, int(count * sizeof(T)), MPI_BYTE, root, tag, comm, &req);
      wait_yielding(req);
    }
    return;
  }
  std::vector<T> buf[2] = {std::vector<T>(std::min(chunk, n)), std::vector<T>(std::min(chunk, n))};
  for (int src = 0; src < nranks; ++src) {
    if (src == root) continue;
    int go = 1;
    MPI_Send(&go, 1, MPI_INT, src, tag, comm);
    if (messages == 0) continue;
    MPI_Request req;
    auto post = [&](size_t m) {
      size_t first = m * chunk, count = std::min(chunk, n - first);
      MPI_Irecv(buf[m % 2].data(), int(count * sizeof(T)), MPI_BYTE, src, tag, comm, &req);
    };
    post(0);
    for (size_t m = 0; m < messages; ++m) {
      MPI_Status status;
      wait_yielding(req, &status);
      size_t first = m * chunk, count = std::min(chunk, n - first);
      int bytes = 0;
      MPI_Get_count(&status, MPI_BYTE, &bytes);
      if (size_t(bytes) != count * sizeof(T))
        throw Error("mpi: rank " + std::to_string(src) + " sent " + std::to_string(bytes) + " bytes instead of " +
                    std::to_string(count * sizeof(T)));
      if (m + 1 < messages) post(m + 1);
      merge(buf[m % 2].data(), first, count);
    }
  }
}

}  // namespace detail

// Adds every rank's film onto root's, in rank order (root's own first).
// Collective; the other ranks' films are left as they were. All films must
// have the same size. Returns the seconds this rank spent.
inline double reduce_film(Film& film, int root = 0, MPI_Comm comm = MPI_COMM_WORLD) {
  auto start = std::chrono::steady_clock::now();
  const int r = rank(comm), n = size(comm);
  // What each rank holds: size, encoding, whether it has splats.
  long long mine[4] = {film.width(), film.height(), film.encoding() == FilmEncoding::xyz ? 1 : 0,
                       film.splats().empty() ? 0 : 1};
  std::vector<long long> all(r == root ? size_t(4) * size_t(n) : 0);
  MPI_Gather(mine, 4, MPI_LONG_LONG, all.data(), 4, MPI_LONG_LONG, root, comm);
  // The root checks; on a mismatch it aborts the job (the others are already
  // sending and could not be told to stop).
  bool any_splats = mine[3] != 0;
  if (r == root) {
    for (int q = 0; q < n; ++q) {
      const long long* h = &all[size_t(q) * 4];
      if (h[0] != mine[0] || h[1] != mine[1])
        throw Error("mpi: rank " + std::to_string(q) + "'s film is " + std::to_string(h[0]) + "x" +
                    std::to_string(h[1]) + ", the root's " + std::to_string(mine[0]) + "x" + std::to_string(mine[1]));
      if (h[2] != mine[2]) throw Error("mpi: rank " + std::to_string(q) + "'s film has another colour encoding");
      any_splats = any_splats || h[3] != 0;
    }
  }
  int splat_flag = any_splats ? 1 : 0;
  MPI_Bcast(&splat_flag, 1, MPI_INT, root, comm);
  const size_t pixels = film.pixels().size();
  detail::reduce_in_rank_order(
      film.pixels().data(), pixels,
      [&](const Film::Pixel* src, size_t first, size_t count) { film.merge_pixels(src, first, count); }, root, comm,
      0x5e1);
  if (splat_flag) {
    std::vector<double>& splat = film.splats();
    if (splat.empty()) splat.assign(pixels * 3, 0.0);
    detail::reduce_in_rank_order(
        splat.data(), splat.size(),
        [&](const double* src, size_t first, size_t count) {
          for (size_t i = 0; i < count; ++i) splat[first + i] += src[i];
        },
        root, comm, 0x5e2);
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The same for the AOVs (albedo, normal, depth). Collective.
inline double reduce_aovs(AovFilm& aovs, int root = 0, MPI_Comm comm = MPI_COMM_WORLD) {
  auto start = std::chrono::steady_clock::now();
  long long mine[2] = {aovs.width(), aovs.height()};
  std::vector<long long> all(rank(comm) == root ? size_t(2) * size_t(size(comm)) : 0);
  MPI_Gather(mine, 2, MPI_LONG_LONG, all.data(), 2, MPI_LONG_LONG, root, comm);
  for (size_t q = 0; q < all.size() / 2; ++q)
    if (all[2 * q] != mine[0] || all[2 * q + 1] != mine[1])
      throw Error("mpi: rank " + std::to_string(q) + "'s AOV film differs in size from the root's");
  detail::reduce_in_rank_order(
      aovs.pixels().data(), aovs.pixels().size(),
      [&](const AovFilm::Pixel* src, size_t first, size_t count) { aovs.merge_pixels(src, first, count); }, root,
      comm, 0x5e3);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// One rank's part of a distributed render.
struct RankStats {
  double seconds = 0;  // its render (not the reduction)
  uint64_t samples = 0, light_paths = 0, rays = 0, dropped = 0;
  int threads = 0;  // it ran on (RenderStats::threads; fewer than asked if its share has fewer units of work)
  bool cancelled = false;
};

struct DistributedStats {
  RenderStats total;             // on root: sums over the ranks (threads too); seconds is the whole wall time
  std::vector<RankStats> ranks;  // on root: one per rank, in rank order
  RankStats mine;                // this rank's
  double wait_seconds = 0;       // this rank's wait for the slowest rank to finish rendering
  double reduce_seconds = 0;     // then its time in the reduction (root: receiving and adding)
  // Slowest rank's render time over the mean (1 = perfectly balanced); root.
  double imbalance() const {
    if (ranks.empty()) return 1;
    double mx = 0, sum = 0;
    for (const RankStats& s : ranks) {
      mx = std::max(mx, s.seconds);
      sum += s.seconds;
    }
    return sum > 0 ? mx / (sum / double(ranks.size())) : 1;
  }
};

// Renders this rank's share (on opt.threads threads; share() above) into film,
// then reduces the films (and opt.aovs, if set) onto root. Collective: every
// rank calls it with the same scene, camera, film size and options. On
// root, film then holds the whole image.
template <class Scene, class Integrator, class Filter = BoxFilter, class Camera = PerspectiveCamera>
DistributedStats render(const Scene& scene, const Camera& camera, const Integrator& integrator, Film& film,
                        const RenderOptions& opt, Split split = Split::samples, const Filter& filter = Filter{},
                        int root = 0, MPI_Comm comm = MPI_COMM_WORLD) {
  auto start = std::chrono::steady_clock::now();
  const int r = rank(comm), n = size(comm);
  RenderOptions mine = share(opt, split, r, n);
  RenderStats st = prism::render(scene, camera, integrator, film, mine, filter);
  DistributedStats out;
  out.mine.seconds = st.seconds;
  out.mine.samples = st.samples;
  out.mine.light_paths = st.light_paths;
  out.mine.rays = st.rays;
  out.mine.dropped = st.dropped;
  out.mine.threads = st.threads;
  out.mine.cancelled = st.cancelled;

  // Wait (asleep) for the slowest rank; this also separates that wait from the
  // reduction proper in the figures.
  auto wait_start = std::chrono::steady_clock::now();
  MPI_Request barrier;
  MPI_Ibarrier(comm, &barrier);
  detail::wait_politely(barrier);
  out.wait_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wait_start).count();

  // Per-rank figures for the summary, as doubles (exact below 2^53), before
  // the reduction so that the other ranks can leave as soon as they have sent.
  double row[7] = {st.seconds,         double(st.samples), double(st.light_paths), double(st.rays),
                   double(st.dropped), double(out.mine.threads), st.cancelled ? 1.0 : 0.0};
  std::vector<double> rows(r == root ? size_t(7) * size_t(n) : 0);
  MPI_Gather(row, 7, MPI_DOUBLE, rows.data(), 7, MPI_DOUBLE, root, comm);
  if (r == root) {
    for (int q = 0; q < n; ++q) {
      const double* x = &rows[size_t(q) * 7];
      RankStats s;
      s.seconds = x[0];
      s.samples = uint64_t(x[1]);
      s.light_paths = uint64_t(x[2]);
      s.rays = uint64_t(x[3]);
      s.dropped = uint64_t(x[4]);
      s.threads = int(x[5]);
      s.cancelled = x[6] != 0;
      out.ranks.push_back(s);
      out.total.samples += s.samples;
      out.total.light_paths += s.light_paths;
      out.total.rays += s.rays;
      out.total.dropped += s.dropped;
      out.total.threads += s.threads;
      out.total.cancelled = out.total.cancelled || s.cancelled;
    }
  } else {
    out.total = st;
  }
  out.reduce_seconds = reduce_film(film, root, comm);
  if (opt.aovs) out.reduce_seconds += reduce_aovs(*opt.aovs, root, comm);
  out.total.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace prism::mpi
