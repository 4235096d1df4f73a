// delaunay.detect_inversion: after integration, find inverted triangles and decide whether
// single edge flips can repair them (marks them in delaunay.flip_mark for delaunay.flip) or the
// step must be rolled back (particles through each other, an edge crossed from both sides, a
// vertex across more than one edge). It copies `position` into `delaunay.position_prev`, the
// reference for the next step's r⁰·r¹ test (a rollback restores the old position_prev; the copy
// costs the snapshot nothing: will_overwrite): on the device within its marking loop when the
// snapshot takes the old storage, else while the host reads its counters.
// When delaunay.flip has `on_unrepairable: substep` (status kSubstep), inverted triangles that
// single flips cannot repair are left to it instead, together with position_prev (not yet
// overwritten, status kPrevKept), and with `passing: substep` particles through each other too.
// On CUDA, where the core offers it (StepContext::gate), it leaves its decision to the marking
// kernel (nothing inverted, through, crossed twice or too long, few Lawson candidates: the
// stages after it go on without a host wait) and takes it on the host in decide().
// In a decomposed team (run_team; docs/multi-gpu.md "The Delaunay pipelines") it keeps the
// rank's triangulation of the particles it holds and decides with the other ranks.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>

#include "core/base/error.h"
#include "core/backend/exec.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/delaunay/build/build.h"
#include "stages/delaunay/common/host.h"
#include "stages/delaunay/common/team.h"
#include "stages/delaunay/detect_inversion/kernel.h"

namespace ff::delaunay {

// Only a decomposed team (`pipeline run --gpus N`, docs/multi-gpu.md) reads these.
struct DetectInversionParams {
  double band = 0;
  double slack = 0;

  template <class P>
  void describe(P& p) {
    p(band, "band",
      "decomposed team only: how far ghosts reach beyond a rank's slab along x (0: ten mean particle spacings); "
      "widened while the run goes when the triangles near the slab grow")
        .at_least(0);
    p(slack, "slack",
      "decomposed team only: how far a particle may move before the particles are migrated and the triangulations "
      "rebuilt (0: one mean particle spacing)")
        .at_least(0);
  }
};

template <class R>
struct DetectInversionLoops {
  ElementLoop<MarkInversions<R>> mark;
  ElementLoop<CheckInverted<R>> check;
};

// The loops of each backend (detect_inversion/cpu.cpp, detect_inversion/cuda.cu).
template <class R>
DetectInversionLoops<R> detect_inversion_loops(CpuExec);
template <class R>
DetectInversionLoops<R> detect_inversion_loops(CudaExec);

template <class R>
class DetectInversion final : public Stage {
 public:
  static StageDecl declaration() {
    return {"delaunay.detect_inversion",
            "find inverted triangles after integration; mark single-flip repairs or request a rollback",
            schema_of<DetectInversionParams>(),
            {2},
            false};
  }

  template <class Exec>
  DetectInversion(const ParamValues& v, const RunInfo& info, Exec exec)
      : p_(params_from<DetectInversionParams>(v)),
        team_(in_team(info.team) ? info.team : nullptr),
        where_(Exec::where),
        loops_(detect_inversion_loops<R>(exec)),
        mem_(exec.memory()),
        counters_(exec),
        blocks_done_(exec) {}

  std::vector<Access> accesses() const override {
    // halfedge/vertex_edge are written only when no triangulation exists yet (first step).
    return {{ff::fields::position, where_, Mode::read},
            Access::on_demand_write(fields::halfedge, where_),
            Access::on_demand_write(fields::opposite, where_),
            Access::on_demand_write(fields::vertex_edge, where_),
            // Read, then overwritten completely (will_overwrite): no snapshot copy.
            Access::on_demand_write(fields::position_prev, where_),
            Access::step_local_write(fields::flip_mark, where_),
            Access::step_local_write(fields::lawson_candidates, where_),
            Access::step_local_write(fields::lawson_candidate_count, where_),
            {fields::status, Where::host, Mode::readwrite}};
  }
  void configure(State& s) override {
    add_topology_fields(s, "delaunay.detect_inversion");
    // A decomposed team's band and slack in mean particle spacings (the whole state here).
    const double spacing = std::sqrt(s.box.L[0] * s.box.L[1] / double(s.n()));
    band_ = p_.band > 0 ? p_.band : 10 * spacing;
    slack_ = p_.slack > 0 ? p_.slack : spacing;
    if (team_ && !(2 * slack_ < band_))
      throw InputError("delaunay.detect_inversion: the slack " + std::to_string(slack_) +
                       " must be less than half the band " + std::to_string(band_));
  }
  // Requests come from run(), after reading the counters, or, in an attempt it leaves to the
  // device, from decide(). In a decomposed team the stage keeps
  // the rank's triangulation of its held particles (TeamWork::local), refreshes the ghosts'
  // positions the integrator moved, and agrees on its requests with the other ranks.
  Scheduling scheduling() const override {
    Scheduling sch{true, false, false, false};
    sch.decides_on_device = where_ == Where::device;
    sch.team = TeamWork::local;
    sch.ghost_band = band_;
    sch.ghost_slack = slack_;
    sch.fills_gap = true;
    sch.refreshes_ghosts = true;
    sch.communicates = true;
    return sch;
  }

  // The triangulation of the held particles is current (a retry after a rollback rebuilds it
  // again: this is not called then).
  void after_step(StepContext& ctx) override { built_for_ = ctx.state.particles_version(); }

  Outcome run(StepContext& ctx) override {
    if (team_ && ctx.ghosts) return run_team(ctx);
    return run_alone(ctx);
  }

  // An attempt whose run() left the decision to the device (StepContext::gate): wait for the
  // marking's counters and decide as run() would have. The kernel opened the gate exactly when
  // device_decision_open holds for these counters. Then delaunay.lawson's gated launch has
  // consumed the candidates (status kCandidates 0), unless it refused the gate: then they stay
  // for its run without it.
  Decision decide(StepContext& ctx) override {
    State& s = ctx.state;
    const auto h = finish_inspect(ctx);
    const bool open = device_decision_open(h.data(), unsigned(s.field(fields::lawson_candidates).count()));
    const bool consumed = status(s)[kCandidates] != kCandidatesOnDevice;
    Decision d{open, conclude(ctx, h, false, gated_inherited_)};
    if (open && consumed) status(s)[kCandidates] = 0;
    ctx.metrics.set("decided_on_device", open ? 1 : 0);
    if (open) {
      gate_backoff_ = 1;
    } else {
      gate_wait_ = gate_backoff_;
      gate_backoff_ = std::min(2 * gate_backoff_, 64);
    }
    return d;
  }

 private:
  Outcome run_alone(StepContext& ctx) {
    State& s = ctx.state;
    // Whether the triangulation is the one this step started with: not when a stage before this
    // one (delaunay.build, or the first topology stage) built it in this step, which announces
    // position_prev (will_build), so the snapshot holds its step-start copy. Asked before this
    // stage's own writes. (Every delaunay stage declares position_prev on demand; a stage that
    // declared it a plain write would have the snapshot copy it every step, and then no
    // triangulation counts as inherited: a broken one is rolled back to dt_min, never rebuilt.)
    Field* prev_at_start = ctx.at_step_start(fields::position_prev);
    const bool inherited = prev_at_start == &s.field(fields::position_prev);
    const bool fresh = ensure_topology(ctx, *this);
    // delaunay.flip's `on_unrepairable: substep` needs the positions at which the triangulation
    // was valid when something is inverted: position_prev is then written after the counters
    // are read (by this stage when nothing is inverted, else by delaunay.flip).
    const bool substep = status(s)[kSubstep] != 0;
    status(s)[kPrevKept] = 0;
    // The device decides when the core offers it (the stages after this one launch gated on
    // its answer, Scheduling::follows_gate) and the common case can hold: a triangulation
    // inherited from the last step (none built now), no substeps, counters the marking's last
    // block publishes. Its kernel writes the verdict and the candidates' count; decide() reads.
    // Not while the last attempt had more Lawson candidates than its list holds (it would
    // close), and after a closed gate not for a few attempts (1, 2, 4 ... 64 after closures in a
    // row): the stages after it then rarely launch for nothing.
    const unsigned listable = unsigned(s.field(fields::lawson_candidates).count());
    const bool waiting = gate_wait_ > 0 || last_candidates_ > listable;
    if (gate_wait_ > 0) --gate_wait_;
    if (ctx.gate && !waiting && where_ == Where::device && !fresh && !substep && edge_count(s.n()) > 0) {
      launch_inspect(ctx, false, true, ctx.gate);
      status(s)[kCandidates] = kCandidatesOnDevice;
      set_position_version(status(s), s.field(ff::fields::position).version());
      gated_inherited_ = inherited;
      ctx.gate_set = true;
      return Outcome::ok();
    }
    ctx.metrics.set("decided_on_device", 0);
    return conclude(ctx, inspect(ctx, fresh, !substep), fresh, inherited);
  }

  // The host's decision on the marking's counters `h` (run() after inspect, or decide()):
  // metrics, a rollback request, or the status for delaunay.flip and delaunay.lawson.
  Outcome conclude(StepContext& ctx, std::array<unsigned, kInversionCounters> h, bool fresh, bool inherited) {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    const bool substep = status(s)[kSubstep] != 0;
    const bool passing = status(s)[kSubstep] == 2;  // flip's `passing: substep`
    // A rollback helps only if this step broke the triangulation: retried with a smaller Δt,
    // the moves shrink toward the positions the step started from. When the triangulation is
    // already not valid for those (the previous step's overlap correction pushed a particle
    // across its neighbours' edges after Lawson), no Δt repairs it: rebuild it for the step's
    // starting positions and judge this step's moves against that. Only for an inherited
    // triangulation: one built earlier in this step is valid at position_prev (where it was
    // built), the retry builds it again, and the step's start may be anywhere (a stage before
    // the build may have placed the particles anew): judged against a triangulation of the
    // start, the moves since then would look like moves across the whole box.
    bool rebuilt = false;
    Field* start = nullptr;  // asked for only on the way to a rollback; null: unknown (no snapshot)
    if (!fresh && inherited && asks_rollback(h) && (start = ctx.at_step_start(ff::fields::position)) &&
        !valid_at(ctx, *start)) {
      will_build(ctx);  // position_prev too: a rollback after the rebuild restores the old one
      build_topology(s, *start, st);
      for (const Access& a : accesses()) s.field(a.field).acquire(a.where, a.mode, st);
      h = inspect(ctx, false, !substep);
      rebuilt = true;
    }
    ctx.metrics.set("rebuilds", rebuilt ? 1 : 0);
    ctx.metrics.set("inversions", h[kInverted]);
    ctx.metrics.set("repairable", h[kMarked]);
    ctx.metrics.set("lawson_candidates", h[kCandidateCount]);
    last_candidates_ = h[kCandidateCount];

    const char* retry = "; the step is retried with a smaller time step";
    if (h[kThrough] && !passing) {
      auto ids = edge_vertices(s, where_, mem_, int(h[kThroughAt]), st);
      return Outcome::request_rollback("delaunay.detect_inversion: particles " + list_ids(ids) +
                                           " passed through each other (their separation vector reversed, r0.r1 < 0; " +
                                           std::to_string(h[kThrough]) + " such pair(s))" + moved(ctx, ids) + retry,
                                       ids);
    }
    // Substep mode: an edge crossed from both sides, a vertex across several edges, or (with
    // flip's `passing: substep`) an edge whose vector reversed is left to delaunay.flip, which
    // moves the particles of the triangles that stay inverted and of the reversed edges part of
    // the way back (Porro et al. §3).
    // A reversed edge is what two points passing each other closer than their step's move leave
    // (boids meeting nearly head on): on straight paths that miss by b > 0 it is no longer
    // reversed once the remaining move is short enough, so the halving resolves it; a true
    // collision (b = 0) exhausts max_substeps and rolls back.
    if (substep && (h[kInverted] || (passing && h[kThrough]))) {
      status(s)[kPending] = std::int32_t(h[kMarked]);
      status(s)[kPrevKept] = 1;
      ctx.metrics.set("unrepairable", h[kUnrepairable] + h[kTwice]);
      return Outcome::ok();
    }
    if (h[kTwice]) {
      auto ids = edge_vertices(s, where_, mem_, int(h[kTwiceAt]), st);
      return Outcome::request_rollback("delaunay.detect_inversion: the edge between particles " + list_ids(ids) +
                                           " was crossed from both sides (both its triangles inverted; " +
                                           std::to_string(h[kTwice]) + " such edge(s))" + moved(ctx, ids) + retry,
                                       ids);
    }
    if (h[kUnrepairable]) {
      auto ids = triangle_vertices(s, where_, mem_, int(h[kUnrepairableAt]), st);
      return Outcome::request_rollback("delaunay.detect_inversion: the triangle of particles " + list_ids(ids) +
                                           " is inverted and no single edge flip repairs it (a particle crossed "
                                           "more than one edge; " +
                                           std::to_string(h[kUnrepairable]) + " such triangle(s))" + moved(ctx, ids) + retry,
                                       ids);
    }
    status(s)[kPending] = std::int32_t(h[kMarked]);
    if (substep) {
      ctx.metrics.set("unrepairable", 0);
      copy_prev(ctx);
    }
    // Lawson's first round may test only the candidates when nothing is left to repair (repair
    // flips change quads) and the list did not overflow.
    if (h[kMarked] == 0 && h[kInverted] == 0 && h[kCandidateCount] <= s.field(fields::lawson_candidates).count()) {
      status(s)[kCandidates] = std::int32_t(h[kCandidateCount]) + 1;
      set_position_version(status(s), s.field(ff::fields::position).version());
    }
    return Outcome::ok();
  }

  template <class H>
  static bool asks_rollback(const H& h) {
    return h[kThrough] || h[kTwice] || h[kUnrepairable];
  }

  // The marks, counters and Lawson candidates of this step's moves, judged against
  // position_prev (nothing to judge against when the triangulation was just built). With
  // `copy`, leaves position_prev = position (the next step's reference).
  const std::array<unsigned, kInversionCounters>& inspect(StepContext& ctx, bool fresh, bool copy) {
    launch_inspect(ctx, fresh, copy, nullptr);
    return finish_inspect(ctx);
  }

  // inspect's launches; with `gate` (the device loop, counters published) the marking's last
  // block also writes the device decision there (MarkInversions::gate).
  void launch_inspect(StepContext& ctx, bool fresh, bool copy, unsigned* gate) {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    const Mesh m = mesh_view(s, where_);
    const Points<R> pts = points_view<R>(s, ff::fields::position, where_);
    R* prev = s.field(fields::position_prev).data<R>(ctx);
    std::uint8_t* mark = s.field(fields::flip_mark).data<std::uint8_t>(ctx);
    Field& cand = s.field(fields::lawson_candidates);
    counters_.begin(kMinSlots, st);  // the bank the last run's loop reset (reset_next)
    unsigned* c = counters_.ptr();
    const std::size_t E = edge_count(s.n());

    status(s)[kCandidates] = 0;
    MarkInversions<R> f{m, pts, fresh ? nullptr : prev, mark, c, cand.data<std::int32_t>(ctx),
                        unsigned(cand.count()), int(E), counters_.next()};
    // On the device the next step's reference is written by the loop itself when the rollback
    // snapshot takes position_prev's storage (will_overwrite): the loop reads the old values
    // there and writes the field's new storage, so nothing it reads is written and no copy
    // follows it. Without a snapshot (the field itself returned) it is copied after the loop.
    if (copy && where_ == Where::device) {
      Field& before = ctx.will_overwrite(fields::position_prev);
      Field& field = s.field(fields::position_prev);
      if (&before != &field) {
        if (f.prev) f.prev = before.data<R>(ctx);
        f.copy_from = pts.p;
        f.copy_to = field.data<R>(ctx);
        f.copy_points = s.n();
        copy = false;
      }
    }
    // On the device the loop's last block publishes the counters (no copy after the loop).
    const bool publish = where_ == Where::device && E > 0;
    if (publish) {
      f.publish = counters_.landing();
      f.blocks_done = blocks_done_.get(1);
      if (gate) {
        f.gate = gate;
        f.candidate_count = s.field(fields::lawson_candidate_count).data<std::int32_t>(ctx);
      }
    }
    loops_.mark(E, f, st);
    counters_.next_was_reset();
    if (publish) counters_.await_published(st);
    else counters_.start_read(st);
    // The next step's reference, copied on the stream while the host waits for the counters
    // (on CUDA the launches that follow this stage queue behind the copy instead of a gap).
    // Every outcome either keeps it or rolls the step back, which restores the old one.
    if (copy) copy_prev(ctx);
  }

  // inspect's read: waits for the counters (and runs the check of inverted triangles).
  const std::array<unsigned, kInversionCounters>& finish_inspect(StepContext& ctx) {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    const auto& h = counters_.finish_read();
    throw_if_too_long(s, where_, mem_, h[kTooLong], h[kTooLongAt], st, "delaunay.detect_inversion");
    if (h[kInverted]) {
      loops_.check(halfedge_count(s.n()),
                   CheckInverted<R>{mesh_view(s, where_), points_view<R>(s, ff::fields::position, where_),
                                    s.field(fields::flip_mark).data<std::uint8_t>(ctx), counters_.ptr()},
                   st);
      return counters_.read(st);
    }
    return h;
  }

  // position_prev ← position, the next step's reference (a rollback restores the old one).
  void copy_prev(StepContext& ctx) {
    State& s = ctx.state;
    ctx.will_overwrite(fields::position_prev);
    mem_.copy(s.field(fields::position_prev).data<R>(ctx), s.field(ff::fields::position).data<R>(ctx),
              s.field(ff::fields::position).bytes(), ctx.stream);
  }

  // How far the particles `ids` moved in this attempt (minimum image), for the message: what is
  // moving too far when the run stops below dt_min. Empty when the start is unknown.
  std::string moved(StepContext& ctx, const std::vector<std::uint64_t>& ids) {
    Field* start = ctx.at_step_start(ff::fields::position);
    if (!start) return "";
    State& s = ctx.state;
    const R* now = s.field(ff::fields::position).data<R>(ctx);
    const R* before = start->data<R>(ctx);
    const auto box = PeriodicBox<double>::make(s.box.L);
    std::string out = "; in this attempt (Δt = " + format_number(ctx.host_params.dt) + ") they moved by";
    for (std::size_t k = 0; k < ids.size(); ++k) {
      R a[2], b[2];
      mem_.to_host(a, now + 2 * ids[k], sizeof a, ctx.stream);
      mem_.to_host(b, before + 2 * ids[k], sizeof b, ctx.stream);
      const double dx = box.min_image(double(a[0]) - double(b[0]), 0), dy = box.min_image(double(a[1]) - double(b[1]), 1);
      out += (k ? (k + 1 == ids.size() ? " and " : ", ") : " ") + format_number(std::sqrt(dx * dx + dy * dy));
    }
    Field& d = s.field(ff::fields::diameter);
    d.acquire(Where::host, Mode::read, ctx.stream);
    double sigma = 0;
    for (std::size_t i = 0; i < d.count(); ++i)
      sigma = std::max(sigma, d.dtype() == DType::f32 ? double(d.host<float>()[i]) : d.host<double>()[i]);
    return out + " (largest diameter " + format_number(sigma) + ")";
  }

  static std::string format_number(double x) {
    std::ostringstream os;
    os << std::setprecision(3) << x;
    return os.str();
  }

  // Whether every triangle is positive at the positions in `start` (where the previous step
  // left the particles). Only on the way to a rollback: one more pass.
  bool valid_at(StepContext& ctx, Field& start) {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    start.acquire(where_, Mode::read, st);
    const Points<R> pts{start.data<R>(ctx), PeriodicBox<double>::make(s.box.L)};
    counters_.reset(kMinSlots, st);
    loops_.mark(edge_count(s.n()),
              MarkInversions<R>{mesh_view(s, where_), pts, nullptr,
                                s.field(fields::flip_mark).data<std::uint8_t>(ctx), counters_.ptr()},
              st);
    return counters_.read(st)[kInverted] == 0;
  }

  // A decomposed team (docs/multi-gpu.md "The Delaunay pipelines"): the rank's triangulation of
  // its held particles, judged as alone, but only the elements it can trust (common/team.h) may
  // roll the step back; the ranks agree (any request rolls every rank back). Elements it cannot
  // trust (near the band's outer edge, where the local triangulation is not the global one)
  // that break are rebuilt for the current positions instead.
  Outcome run_team(StepContext& ctx) {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    if (status(s)[kSubstep])
      throw RunError("delaunay.detect_inversion: delaunay.flip's on_unrepairable: substep does not run in a "
                     "decomposed team yet");
    ctx.ghosts->refresh(s, {ff::fields::position});  // the integrator moved the owned particles
    add_topology_fields(s, "delaunay.detect_inversion");  // sized for the particles held now
    const auto box = PeriodicBox<double>::make(s.box.L);
    Field* prev_at_start = ctx.at_step_start(fields::position_prev);
    const bool inherited = prev_at_start == &s.field(fields::position_prev);
    bool fresh = false;
    if (!status(s)[kBuilt]) {
      fresh = ensure_topology(ctx, *this);  // the first step: at the moved positions, as alone
    } else if (built_for_ != s.particles_version()) {
      // A migration changed the particles held: triangulate them at position_prev, where the
      // triangulation one rank alone inherits is Delaunay (the fields moved with the particles).
      // The fill vertices beyond the band (Scheduling::fills_gap) came as copies of a particle:
      // they never move, so their position_prev is where they are.
      will_build(ctx);
      Field& prev = s.field(fields::position_prev);
      Field& pos = s.field(ff::fields::position);
      Field& id = s.field(ff::fields::particle_id);
      for (Field* f : {&pos, &id}) f->acquire(Where::host, Mode::read, st);
      prev.acquire(Where::host, Mode::readwrite, st);
      for (std::size_t i = s.n_owned(); i < s.n(); ++i)
        if (id.host<std::uint32_t>()[i] == ff::fields::kFillId)
          for (int k = 0; k < 2; ++k) prev.host<R>()[2 * i + std::size_t(k)] = pos.host<R>()[2 * i + std::size_t(k)];
      build_topology(s, prev, st);
      for (const Access& a : accesses()) s.field(a.field).acquire(a.where, a.mode, st);
    }
    status(s)[kPrevKept] = 0;
    band_check<R>(ctx, "delaunay.detect_inversion", fresh ? ff::fields::position : fields::position_prev);
    auto h = inspect(ctx, fresh, false);
    auto trusted = [&](bool judged) {
      if (!asks_rollback(h)) return false;
      s.field(fields::flip_mark).acquire(Where::host, Mode::read, st);
      const R* prev = judged ? host_positions<R>(s, s.field(fields::position_prev), st) : nullptr;
      return owned_rollback_reason<R>(HostMesh::of(s, st), host_positions<R>(s, s.field(ff::fields::position), st),
                                      prev, s.field(fields::flip_mark).host<std::uint8_t>(), s.n_owned(), box);
    };
    bool mine = trusted(!fresh);
    bool any = any_rank(team_, mine);
    bool rebuilt = false;
    // As alone: a request against an inherited triangulation that is not valid where the step
    // started rebuilds it there and judges again; valid means valid on every rank's trusted part.
    Field* start = nullptr;
    if (any && !fresh && inherited && (start = ctx.at_step_start(ff::fields::position))) {
      const bool invalid = owned_inverted<R>(HostMesh::of(s, st), host_positions<R>(s, *start, st), s.n_owned(), box);
      if (any_rank(team_, invalid)) {
        will_build(ctx);
        build_topology(s, *start, st);
        for (const Access& a : accesses()) s.field(a.field).acquire(a.where, a.mode, st);
        h = inspect(ctx, false, false);
        mine = trusted(true);
        any = any_rank(team_, mine);
        rebuilt = true;
      }
    }
    bool local_rebuild = false;
    if (!any && asks_rollback(h)) {
      will_build(ctx);
      build_topology(s, st);  // position_prev = position too
      for (const Access& a : accesses()) s.field(a.field).acquire(a.where, a.mode, st);
      local_rebuild = true;
    } else {
      copy_prev(ctx);
    }
    ctx.metrics.set("rebuilds", rebuilt ? 1 : 0);
    ctx.metrics.set("local_rebuilds", local_rebuild ? 1 : 0);
    ctx.metrics.set("inversions", h[kInverted]);
    ctx.metrics.set("repairable", h[kMarked]);
    ctx.metrics.set("lawson_candidates", h[kCandidateCount]);
    if (any)
      return Outcome::request_rollback(
          mine ? "delaunay.detect_inversion: on this rank of the team, " + std::to_string(h[kThrough]) +
                     " pair(s) of particles passed through each other, " + std::to_string(h[kTwice]) +
                     " edge(s) were crossed from both sides or " + std::to_string(h[kUnrepairable]) +
                     " inverted triangle(s) cannot be repaired by single flips; the step is retried with a smaller "
                     "time step"
               : "delaunay.detect_inversion: another rank of the team found inverted triangles that single flips "
                 "cannot repair; the step is retried with a smaller time step");
    if (local_rebuild) return Outcome::ok();  // nothing pending: built for these positions
    status(s)[kPending] = std::int32_t(h[kMarked]);
    if (h[kMarked] == 0 && h[kInverted] == 0 && h[kCandidateCount] <= s.field(fields::lawson_candidates).count()) {
      status(s)[kCandidates] = std::int32_t(h[kCandidateCount]) + 1;
      set_position_version(status(s), s.field(ff::fields::position).version());
    }
    return Outcome::ok();
  }

  static constexpr std::array<int, 4> kMinSlots{kThroughAt, kTwiceAt, kUnrepairableAt, kTooLongAt};
  DetectInversionParams p_;
  Communicator* team_;  // a decomposed team's rank; null alone
  double band_ = 0, slack_ = 0;
  std::uint64_t built_for_ = ~std::uint64_t(0);  // particles_version of the last accepted step's triangulation
  bool gated_inherited_ = false;  // a device-decided attempt: whether its triangulation was inherited (decide)
  int gate_wait_ = 0;     // attempts left before the gate is tried again (run_alone)
  unsigned last_candidates_ = 0;  // the Lawson candidates of the last attempt decided (conclude)
  int gate_backoff_ = 1;  // the wait after the next closed gate
  Where where_;
  DetectInversionLoops<R> loops_;
  const MemoryOps& mem_;
  Counters<kInversionCounters> counters_;
  Scratch<unsigned> blocks_done_;  // the device loop's finished blocks (MarkInversions::blocks_done)
};

}  // namespace ff::delaunay

FLIPFLOW_STAGE(ff::delaunay::DetectInversion)
