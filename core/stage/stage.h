// The stage interface: what every integrate / topology / correction / observe step implements.
// A stage declares the fields it touches (where and how), is configured once, and runs once
// per step on the backend it was built for. It returns continue, request-rollback or a limit on
// the step's Δt; it never wires graph edges or synchronizes with other stages. nvcc-clean: CUDA
// stages include it.
#pragma once
#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/base/error.h"
#include "core/backend/field.h"
#include "core/stage/params.h"
#include "core/physics/rng.h"
#include "core/stage/stage_state.h"
#include "core/stage/state.h"
#include "core/stage/step_params.h"
#include "core/base/types.h"

namespace ff {

struct Access {
  std::string field;
  Where where = Where::host;
  Mode mode = Mode::read;
  // For writes that happen only on some steps (a triangulation that changes only when something
  // flips): the rollback snapshot copies the field only when the stage announces the write with
  // StepContext::will_write (or will_overwrite) before it, instead of before every step.
  bool on_demand = false;
  // For scratch fields that carry nothing from one step to the next (every step writes what it
  // reads of them before reading it: detect_inversion's flip marks and Lawson candidates, a pair
  // force's `force`): a retried step rewrites them anyway, so the rollback snapshot does not copy
  // this write. The core checks the promise against the pipeline: where the stage does not run
  // every step, or a stage that reads the field is not ordered after it (a force read before the
  // stage that computes it, i.e. from the previous step), the write is copied like any other.
  bool step_local = false;

  // {field, where, mode} for the plain cases; these name the two special kinds of write.
  static Access on_demand_write(std::string field, Where where, Mode mode = Mode::readwrite) {
    return Access{std::move(field), where, mode, true, false};
  }
  static Access step_local_write(std::string field, Where where, Mode mode = Mode::write) {
    return Access{std::move(field), where, mode, false, true};
  }
};

struct Outcome {
  bool rollback = false;
  std::string reason;                   // why, in words a user can act on
  std::vector<std::uint64_t> particles; // particles involved (first few are reported)
  // The largest Δt this step may take (limit_dt); infinity: no limit.
  double dt_limit = std::numeric_limits<double>::infinity();

  static Outcome ok() { return {}; }
  static Outcome request_rollback(std::string why, std::vector<std::uint64_t> who = {}) {
    return Outcome{true, std::move(why), std::move(who)};
  }
  // "Δt must not exceed dt_max in this step" (a stage that needs Scheduling::may_limit_dt). Not a
  // failure: return it every step, also when the attempt's Δt is within it, so the core knows the
  // limit when it regrows Δt. When the attempt's Δt exceeds dt_max the core stops the attempt
  // and runs the step again, with the same attempt number (the same noise), at the largest
  // run.dt/2^k <= dt_max (DtController), counted in RunStats::dt_limits, not as a rollback.
  static Outcome limit_dt(double dt_max, std::string why, std::vector<std::uint64_t> who = {}) {
    return Outcome{false, std::move(why), std::move(who), dt_max};
  }
  bool limits_dt() const { return dt_limit < std::numeric_limits<double>::infinity(); }
};

// Per-step numbers a stage reports (flips, overlap iterations, ...). Written by one stage only.
class Metrics {
 public:
  void set(const std::string& name, double value) { values_[name] = value; }
  // A count over particles or pairs (pairs felt): in a decomposed team each rank counts its own
  // particles' and the core sums the ranks' values; every other metric takes the largest value
  // over the ranks (a maximum, or a decision every rank shares).
  void set_sum(const std::string& name, double value) {
    values_[name] = value;
    sums_.insert(name);
  }
  bool is_sum(const std::string& name) const { return sums_.count(name) != 0; }
  const std::map<std::string, double>& values() const { return values_; }
  void clear() {
    values_.clear();
    sums_.clear();
  }

 private:
  std::map<std::string, double> values_;
  std::set<std::string> sums_;
};

// What produced a run, for outputs to record (observe.h5md writes it under /parameters): the
// effective pipeline after --set, the overrides, the software and the machine, and for a
// continued run (--resume) what it changed.
struct RunRecord {
  std::string pipeline_text;       // the pipeline file as given (empty: read pipeline_file)
  std::string effective_pipeline;  // the resolved pipeline, --set applied (YAML)
  std::string resolved;            // every parameter after defaults and --set, "key = value" lines
  std::vector<std::string> overrides;                               // the --set arguments
  std::vector<std::pair<std::string, std::string>> attributes;      // version, commit, device, ...
  // A continued run: the step it continues from and what changed ("" when nothing); empty
  // resumed_from for a fresh run.
  std::string resumed_from;        // the checkpoint file
  std::uint64_t resume_step = 0;
  std::string changes;
};

class Communicator;  // core/backend/comm.h

// What the core knows about the run as a whole; given to factories and to every step.
struct RunInfo {
  int dim = 2;
  Precision precision = Precision::f64;
  Backend backend = Backend::cpu;
  std::uint64_t seed = 0;
  std::uint64_t steps = 0;       // steps the run will take
  double dt = 0;                 // configured (nominal) time step
  std::string out_dir;           // where outputs go (created by the core before the run)
  std::string pipeline_file;     // the YAML the run came from (recorded in outputs)
  std::string stage_id;          // this stage's id in the step graph
  RunRecord record;              // what produced the run (outputs record it)
  // The team this rank belongs to (`pipeline run --gpus N`, core/backend/comm.h), or null when
  // the run is alone. A stage whose Scheduling::team is TeamWork::split divides its work through
  // it; in a decomposed team the core does every exchange (TeamWork).
  Communicator* team = nullptr;
  // Where the run's messages to its user go (progress lines, warnings, what a failed run kept):
  // stderr, or the run's own log when it shares its process with other runs (`pipeline sweep
  // --in-process` gives each run its run.log), so that no run's lines land among another's.
  std::FILE* messages = stderr;
};

// Whole-run observables the core keeps (observe stages write them out).
struct RunStats {
  std::uint64_t rollbacks = 0;        // since the start of the run
  std::uint64_t step_rollbacks = 0;   // in the last accepted step
  // Attempts stopped because a stage limited Δt below the attempt's (Outcome::limit_dt) and run
  // again at the limited Δt: since the start of the run, and in the last accepted step.
  std::uint64_t dt_limits = 0;
  std::uint64_t step_dt_limits = 0;
  // The smallest limit the stages reported in the last accepted step (infinity: none).
  double dt_limit = std::numeric_limits<double>::infinity();
  double dt = 0;                      // Δt of the last accepted step
  // Last reported metrics, keyed "stage_id/metric".
  std::map<std::string, double> metrics;
  // When each metric was last reported, on the accepted state's clock (what observers see: a
  // compute stage's metric of step s carries step s + 1, an observer's its own step). A metric
  // of a stage that skips steps stays in `metrics` between its runs; its stamp tells a writer
  // that the value is not new (observe.h5md writes it once, at the step it was measured).
  struct Stamp {
    std::uint64_t step = 0;
    double time = 0;
    std::uint64_t reports = 0;  // how many times it was reported since the run started
    // Reported by an observer without a file of its own (observe.msd): observe.h5md is its only
    // record, so a value it does not write is lost.
    bool only_in_observables = false;
  };
  std::map<std::string, Stamp> metric_stamps;
};

class Snapshot;  // core/run/rollback.h

// A CUDA stage that finds a reason to roll back sets `requested` (non-zero: a stage-defined
// code) and `particle` from its kernel; the core reads all flags once per step, so no stage
// waits for the GPU to decide. Zeroed by the core before every attempt.
struct DeviceRollbackFlag {
  unsigned int requested;
  unsigned int particle;
};

// The step's clock (step, attempt, Δt, time) reaches a stage on two sides, for two uses:
//  - `params` (StepParams, core/stage/step_params.h) on the stage's side, for kernels: host
//    memory on the CPU, a device copy on CUDA that the core keeps current (a kernel at the end
//    of a captured step advances it; the host rewrites it after a rollback or a Δt change). It
//    is the one way per-step values reach kernels: a stage whose kernels read them there can be
//    captured once into a CUDA graph and replayed every step (Scheduling::graph_capturable).
//  - `host_params`, the same values on the host, for host logic only: messages, observers, what
//    run() decides on the host. Never pass them to a kernel: a captured graph would replay the
//    values of the step it was captured in.
// A decomposed team's ghost exchange (core/run/domain.h), for a stage that moves its owned
// particles and must read the ghosts' new values within its own step (overlap_correct.verlet's
// iterations): sends the owners' entries of `fields` to the ranks that hold them as ghosts.
// Every rank must call it at the same point (Scheduling::communicates).
class GhostExchange {
 public:
  virtual ~GhostExchange() = default;
  // Sends from the side the fields are current on (on CUDA: from the device when every field
  // is current there, else from the host; only that side is current after it), so a stage that
  // wrote them after the scheduler's acquire acquires them again for writing, on its side,
  // before calling it.
  virtual void refresh(State& state, const std::vector<std::string>& fields) = 0;
  // Asks for ghosts within at least `band` of the slab from the next step on: the core takes the
  // largest request of any rank at the start of the next step and migrates with the wider band
  // (delaunay.detect_inversion, when the triangles near the owned particles grow). Local: no
  // message, every rank may call it or not.
  virtual void request_band(double band) = 0;
  // How far ghosts reach beyond the slab now (it only grows).
  virtual double band() const = 0;
  // The largest distance between any particle's entry of `field` (positions, real x dim) and its
  // position at the last migration, over the team (minimum image; one all-reduce: every rank
  // calls it at the same point).
  virtual double displacement(State& state, const std::string& field) = 0;
};

struct StepContext {
  // step, attempt, dt and time fill host_params; the rest are the members of the same names.
  StepContext(State& s, const RunInfo& info, const RunStats& st, std::uint64_t step, std::uint32_t attempt, double dt,
              double time, Backend b, CUstream_st* str, RngKey key, Metrics& m, DeviceRollbackFlag* flag = nullptr,
              const StepParams* p = nullptr, Snapshot* snap = nullptr)
      : state(s), run(info), stats(st), host_params{step, attempt, dt, time}, backend(b), stream(str), rng(key),
        metrics(m), device_rollback(flag), params(p), snapshot(snap) {}

  State& state;
  const RunInfo& run;
  const RunStats& stats;
  // On the host, for host logic (above): step is the step being computed (state.step before it
  // is accepted; for an observer, the steps done), attempt 0 for the first try and +1 for each
  // rollback of this step, dt the Δt of this attempt, time the simulated time at its start.
  StepParams host_params;
  Backend backend;
  CUstream_st* stream;     // the CUDA stream the core assigned (nullptr on the CPU)
  RngKey rng;              // (seed, this stage)
  Metrics& metrics;
  DeviceRollbackFlag* device_rollback;  // device memory; CUDA runs only
  const StepParams* params;             // for kernels, on the stage's side (above)
  // The core's rollback snapshot; null when nothing can roll back this stage's writes (no
  // stage may request a rollback, or every one that may runs before this stage and requests
  // only from run(): always so on the CPU).
  Snapshot* snapshot;
  // In a decomposed team: the ghost exchange (null alone and in a replicated team).
  GhostExchange* ghosts = nullptr;

  // Whether the stage may leave reading its results back (and announcing the on-demand writes
  // that depend on them) to after_step, so that the stages after it queue behind its kernels
  // instead of waiting for the host: true when no rollback can undo its writes in this attempt
  // (no snapshot covers them). When false, a rollback may restore what it writes, so it must
  // announce an on-demand write (will_write) before making it, which needs its results now.
  bool may_defer_read_back() const { return snapshot == nullptr; }
  // Whether the stage may leave that read past the end of the step, to its next run() or to
  // settle_pending(), so that the next step's first kernels queue behind its own instead of
  // behind a wait for the host: true alone (not in a team) when may_defer_read_back() and the core
  // needs nothing of this step before the next one starts (no observer looks at it; not
  // profiling), on either backend (on the CPU there is no device to keep busy: a stage defers
  // there only to be tested, tests/plugins/testing_plugin.cpp's testing.defer). Its work must
  // then end without the host (a stage that may need more launches after reading its results
  // cannot defer). The core has it settled before anything looks at the step (Simulation::stats()
  // and synchronize(), observers, checkpoints, the end of the run), so readers of the metrics see
  // the step's; errors are thrown there.
  bool may_defer_past_step() const { return may_defer_read_back() && step_may_end_pending; }
  // Set by the core (see may_defer_past_step).
  bool step_may_end_pending = false;

  // Device decisions (Scheduling::decides_on_device and follows_gate): in a chain of stages,
  // alone, a stage whose host decision is nearly always "go on" may leave it to its kernels, so
  // the stages after it launch theirs before the host has read anything (no wait for the device
  // in the step). `gate` is a word the core keeps, in device memory on CUDA (on the CPU in host
  // memory, which a stage writes and reads in run(): stages decide there only to be tested,
  // tests/plugins/testing_plugin.cpp's testing.decide and testing.follow):
  //  - the decider sees it non-null when it may decide so in this attempt. A run() that does
  //    launches kernels that write *gate (0: the common case, the stages after it may go on;
  //    non-zero: the host must decide), sets gate_set and returns Outcome::ok() without waiting
  //    for the device; the core calls its decide() once the rest of the chain is enqueued.
  //  - a follower sees it non-null when the decider set it in this attempt. Its kernels read
  //    *gate, and while it is non-zero change no field and leave the stage's own device state as
  //    after a run with nothing to do; the core then runs the follower again without the gate in
  //    the same attempt, after the host's decision. A follower that cannot follow in this
  //    attempt (what it needs is not there) sets gate_refused before launching anything: the core
  //    closes the gate, so the stages after it do nothing either, and runs it and them again.
  unsigned* gate = nullptr;
  bool gate_set = false;      // (the decider's answer)
  bool gate_refused = false;  // (a follower's answer)

  // Call before first writing a field declared with Access::on_demand in this step: the
  // rollback snapshot takes its copy now (once per step; a no-op when nothing can roll back the
  // write). Stream-ordered on `stream`.
  void will_write(const std::string& field) const;
  // Instead of will_write, for an on_demand field whose every element the stage is about to
  // write (detect_inversion's position_prev, abp.integrate's position): the snapshot keeps the
  // field's storage and hands it other storage with stale contents, so nothing is copied.
  // Returns where the contents before the call are now: the snapshot's copy (read the old
  // values there, write the field), or the field itself when no snapshot takes this write
  // (update in place). Pointers to the field taken before the call may point to the copy
  // afterwards: take them again. A graph-capturable stage may call it: the core captures no step
  // that has a rollback snapshot, so in a captured step it returns the field itself.
  Field& will_overwrite(const std::string& field) const;
  // The contents `field` had at the start of this step (before any stage of the step wrote it):
  // the rollback snapshot's copy when a stage before this one wrote it, else the field itself;
  // null when this stage has no snapshot (nothing can roll it back), so the core cannot tell.
  // Exact for a stage that may request a rollback (the snapshot then holds every write made
  // before it in the step); read it, never write it. detect_inversion uses it to tell a
  // triangulation this step broke from one the step inherited broken.
  Field* at_step_start(const std::string& field) const;
};

// How a stage runs in a team of ranks (`pipeline run --gpus N`; core/backend/comm.h), where
// every rank holds the whole state and runs every compute stage (observers run on rank 0 only):
//  - redundant: each rank runs the stage on its own copy of the state and gets the same bits as
//    the others (the default: every stage is deterministic for any thread count, so this holds
//    for any stage that writes no files);
//  - split: the stage does a 1/N share of its work on each rank and exchanges the results
//    (RunInfo::team), so every rank ends the stage with the same state one rank alone would
//    have (phoretic.forces, range: long: each rank sums its slice of targets, the velocities
//    are all-gathered).
// The core refuses a team in which no stage splits (N copies of one run) and a compute stage
// that writes files (all ranks would write them).
// A team can also be *decomposed* (core/run/domain.h, docs/multi-gpu.md): each rank holds only
// the particles of its slab along x plus ghosts, copies of the particles near it, and every
// compute stage must say it can work so:
//  - decomposed: the stage computes results for the owned particles [0, State::n_owned()) only;
//    it may read the ghosts' values of what it reads (Scheduling::reads_ghosts). The core
//    refreshes the ghosts' entries of every particle field it writes at the start of each step;
//  - local: the stage computes this rank's own data from every particle it holds, owned and
//    ghost (a Verlet list, indexed by the rank's particle numbers): never exchanged, rebuilt
//    when the particles held change (State::particles_version()). Scheduling::ghost_band says how
//    far from the slab ghosts must reach for its data to be exact for the owned particles.
enum class TeamWork { redundant, split, decomposed, local };

// What a stage tells the core about how it may be scheduled. Everything defaults to "no".
struct Scheduling {
  // run() can return request_rollback: only then does the core snapshot the state.
  bool may_request_rollback = false;
  // On CUDA the stage may also ask for a rollback from its kernels (StepContext::device_rollback,
  // read only at the end of the step, after every later stage ran), so the core snapshots the
  // writes of the stages after it too. A stage whose requests all come from run() leaves it
  // false: then, as on the CPU, a request stops the step before the stages after it.
  bool requests_rollback_on_device = false;
  // On CUDA, run() only enqueues device work on ctx.stream, never synchronizes or reads the
  // host, and its kernels take step-dependent values from ctx.params (never from
  // ctx.host_params). When every compute stage says so, none uses `every` or `at` and no stage
  // may request a rollback (a step with a snapshot is never captured, so will_write and
  // will_overwrite are free to swap storage or copy), the core captures the step once as a CUDA
  // graph and replays it.
  bool graph_capturable = false;
  // run() passes ctx.params to its kernels: on CUDA the core then keeps a device copy of the
  // step's parameters (one upload per step, none while a captured graph advances it).
  bool reads_step_params = false;
  // run() may return Outcome::limit_dt. The core then snapshots (and restores before running
  // the step again at the limited Δt) what the stages that can run before this one write, as it
  // does for a rollback request from run(); placed first in the step, the stage costs no copy.
  bool may_limit_dt = false;
  // In a team of ranks: TeamWork above.
  TeamWork team = TeamWork::redundant;
  // A decomposed stage that reads values of particles other than its owned ones (neighbours):
  // the ghosts then hold the values of the start of the step, so no stage before it in the step
  // may write a particle field it reads (checked).
  bool reads_ghosts = false;
  // A local stage (TeamWork::local): its data for the owned particles is exact while every
  // particle within ghost_band (along x) of the rank's slab, as it was at the last migration, is
  // held, and no particle has moved more than ghost_slack since then (the core migrates, and
  // renews the ghosts, before any particle has). A Verlet list: cutoff + skin and skin/2, built
  // at every migration; or, with a ghost_margin M, cutoff + 2 skin + 2M and skin/2 + M, rebuilt
  // between migrations on its own (stages/neighbors/verlet/stage.h).
  double ghost_band = 0;
  double ghost_slack = 0;
  // A decomposed stage that moves particles after the list was built, within the step (the
  // overlap correction): how far it may move one. The core migrates that much earlier (the local
  // stages' slack less this), so the ghosts still cover every pair after its moves (and a list
  // rebuilt within the step, where the band has room: GhostExchange::displacement).
  double ghost_reserve = 0;
  // A decomposed stage that exchanges with the other ranks inside run() (StepContext::ghosts, an
  // all-reduce through RunInfo::team): every rank must reach it, so no stage before it in the
  // step may request a rollback or limit Δt (a rank whose stage did stops its step there).
  // A communicating stage that may request a rollback agrees on it within run() (an all-reduce):
  // every rank returns the same request or none, so it does not count as a stage that may stop
  // one rank's step (delaunay.detect_inversion and delaunay.flip in a decomposed team).
  bool communicates = false;
  // A local stage that reads the ghosts' values of particle fields that decomposed stages wrote
  // earlier in the step: its run() first refreshes them (StepContext::ghosts), so it and the
  // stages after it read current ghosts (delaunay.detect_inversion refreshes `position` after the
  // integrator). It exchanges, so it counts as communicating for the checks above.
  bool refreshes_ghosts = false;
  // A local stage that triangulates the held particles (the Delaunay stages): the core adds
  // fixed vertices after the ghosts that fill the gap beyond the band (x farther than
  // ghost_band from the slab), so that no edge of the rank's triangulation spans it
  // (stages/delaunay/common/slab.h: global coordinates with a gap). Their particle.id is
  // kFillId; no stage moves them and no one owns them.
  bool fills_gap = false;
  // The stage may leave its host decision to its kernels (StepContext::gate) and take it in
  // decide(). The core offers it in a chain whose every compute stage after this one
  // follows_gate, alone, when not profiling; FLIPFLOW_DEVICE_DECISIONS=0 turns it off.
  bool decides_on_device = false;
  // The stage launches its work gated on a decider's device decision (StepContext::gate).
  bool follows_gate = false;
  // Not a hint but the core's answer, per attempt: whether a stage may defer reading its results
  // back to after_step is StepContext::may_defer_read_back().
};

class Stage {
 public:
  virtual ~Stage() = default;
  // Fields read and written, and on which side. The core derives graph checks, host/device
  // copies and the rollback snapshot from this list. Called after configure().
  virtual std::vector<Access> accesses() const = 0;
  // Once, before the first step: add fields this stage owns, check preconditions. May throw
  // InputError (bad combination of parameters and system) or RunError.
  virtual void configure(State& state) { (void)state; }
  virtual Outcome run(StepContext& ctx) = 0;
  // Once per attempt, after every compute stage of the step has run (its device work enqueued),
  // for each stage that ran, in step order; not when a stage requested a rollback or failed,
  // and, for a step replayed from a CUDA graph, only if the stage reads ctx.params
  // (Scheduling::reads_step_params: its kernels know the step they run in). There run() was not
  // called and ctx.stream is the stream the graph was launched on: after_step may look at host
  // memory its kernels write themselves and record fences, but not read back what run() started
  // (that was captured once). The overdamped integrators' non-finite check does so. A CUDA stage that left its results on the
  // device (so that the stages after it queue behind its kernels instead of waiting for the
  // host) reads them here: it sets its metrics and throws RunError on what they report. It must
  // not request a rollback, and must cope with not being called (a later stage's rollback):
  // its next run() then settles what is pending.
  virtual void after_step(StepContext& ctx) { (void)ctx; }
  // Reads back what a run() left pending past its step (StepContext::may_defer_past_step): sets
  // the metrics of that step and throws RunError on what they report. The core calls it on every
  // compute stage where it needs the results (a no-op without a pending read); the stage's next
  // run() must settle first too.
  virtual void settle_pending(StepContext& ctx) { (void)ctx; }
  // Scheduling::decides_on_device: the host's decision of an attempt whose run() left it to the
  // device (StepContext::gate_set), called once the stages after it are enqueued, with the same
  // context run() had. Waits for what its kernels found, sets the metrics and decides as run()
  // would have: `open` says whether its kernels opened the gate (then the outcome is ok and the
  // followers' gated work stands), the outcome what the step does (a rollback, or ok: with the
  // gate closed the core then runs the followers again).
  struct Decision {
    bool open = false;
    Outcome outcome;
  };
  virtual Decision decide(StepContext& ctx) {
    (void)ctx;
    throw RunError("a stage set StepContext::gate_set without overriding Stage::decide");
  }
  // Once, after the last step or when the run stops early: flush and close outputs.
  virtual void finish(State& state, bool completed) { (void)state; (void)completed; }
  // Files this stage will create (relative to out_dir): checked before anything is written.
  virtual std::vector<std::string> outputs() const { return {}; }
  // How the core may schedule this stage (Scheduling above); the defaults suit a stage that never
  // asks for a rollback and is not replayed from a CUDA graph.
  virtual Scheduling scheduling() const { return {}; }
  // Checkpoints (core/run/checkpoint.h). save_state: between steps, after the observers, store
  // what this stage keeps outside the state's fields that a continued run needs to give the same
  // bits (the default: nothing; fields are the core's). An observer also makes what it has
  // written so far durable here, so the checkpoint never runs ahead of its files.
  // restore_state: in a continued run, after configure() and after the core restored every
  // field and the clock (state.step is the checkpoint's step), before the first step; `saved`
  // is what save_state stored (empty if it stored nothing). An observer reopens its files here,
  // dropping what was written after state.step.
  virtual void save_state(StageState& out) { (void)out; }
  virtual void restore_state(const StageState& saved, State& state) { (void)saved; (void)state; }
};

}  // namespace ff
