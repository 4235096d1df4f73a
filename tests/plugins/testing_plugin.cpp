// Stages that exist only to test the core: they request rollbacks or limit Δt on cue, prove that
// two stages ran at the same time, and record the order stages ran in. Built into test-plugins/,
// never into the plugins users see.
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#ifdef FLIPFLOW_HAVE_CUDA
#include <cuda_runtime.h>
#endif

#include "core/backend/comm.h"
#include "core/base/error.h"
#include "core/stage/plugin_api.h"

namespace {

using namespace ff;

// testing.rollback: on the listed steps, requests a rollback on the first `fail_attempts`
// attempts, after scrambling the positions (so only a correct restore gives the right answer).
// With dt_above > 0 it also requests a rollback whenever Δt > dt_above. It always requests from
// run(); with device_requests it says it may also request from kernels on CUDA (as a stage
// using StepContext::device_rollback would), so the core snapshots the stages after it there.
// With scramble_undeclared it also scrambles `type`, which it does not declare: a broken stage
// that only RunOptions::check_rollbacks can catch. With rank >= 0 it acts only on that rank of a
// team (RunInfo::team; alone, a run is rank 0), so the other ranks must follow the agreement.
int rank_of(const RunInfo& info) { return info.team ? info.team->rank() : 0; }

class RequestRollback final : public Stage {
 public:
  RequestRollback(const ParamValues& v, const RunInfo& info)
      : active_(v.integer("rank") < 0 || v.integer("rank") == rank_of(info)),
        steps_(v.reals("steps")),
        fail_attempts_(v.integer("fail_attempts")),
        dt_above_(v.real("dt_above")),
        device_requests_(v.boolean("device_requests")),
        scramble_undeclared_(v.boolean("scramble_undeclared")) {}
  std::vector<Access> accesses() const override { return {{fields::position, Where::host, Mode::readwrite}}; }
  // Decomposed: it touches only what its rank holds (and a rollback undoes it), so a decomposed
  // team may run it too (tests/test_decomposition.cpp).
  Scheduling scheduling() const override {
    Scheduling s{true, device_requests_, false, false};
    s.team = TeamWork::decomposed;
    return s;
  }
  Outcome run(StepContext& ctx) override {
    bool listed = false;
    for (double s : steps_) listed = listed || std::uint64_t(s) == ctx.host_params.step;
    const bool fail = active_ && ((listed && ctx.host_params.attempt < std::uint32_t(fail_attempts_)) ||
                                  (dt_above_ > 0 && ctx.host_params.dt > dt_above_));
    ctx.metrics.set("attempt", ctx.host_params.attempt);
    if (!fail) return Outcome::ok();
    Field& f = ctx.state.field(fields::position);
    if (f.dtype() == DType::f64) {
      double* x = f.host<double>();
      for (std::size_t i = 0; i < f.size(); ++i) x[i] = -1e9 + double(i);
    }
    if (scramble_undeclared_) {
      Field& t = ctx.state.field(fields::type);
      t.acquire(Where::host, Mode::readwrite);
      for (std::size_t i = 0; i < t.size(); ++i) t.host<std::int32_t>()[i] += 7;
    }
    return Outcome::request_rollback("testing.rollback asked for it", {3, 1, 4});
  }

 private:
  bool active_;
  std::vector<double> steps_;
  std::int64_t fail_attempts_;
  double dt_above_;
  bool device_requests_;
  bool scramble_undeclared_;
};

// testing.barrier: two instances with the same `group` wait (bounded) for each other. Metric
// `overlapped` = 1 when the partner arrived while this one was still running: only possible
// when the scheduler ran them concurrently. Arrivals only ever count up: the k-th pair of a
// group is complete once 2k+2 stages have arrived (no reset, so no race between steps).
std::atomic<int> g_arrivals[4];
class Barrier final : public Stage {
 public:
  explicit Barrier(const ParamValues& v) : group_(int(v.integer("group"))), field_(v.string("field")) {}
  std::vector<Access> accesses() const override {
    if (field_.empty()) return {};
    return {{field_, Where::host, Mode::read}};
  }
  Outcome run(StepContext& ctx) override {
    const int me = g_arrivals[group_].fetch_add(1);
    const int pair_complete = (me / 2) * 2 + 2;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    bool overlapped = false;
    while (!(overlapped = g_arrivals[group_].load() >= pair_complete) && std::chrono::steady_clock::now() < deadline)
      std::this_thread::yield();
    ctx.metrics.set("overlapped", overlapped ? 1 : 0);
    return Outcome::ok();
  }

 private:
  int group_;
  std::string field_;
};

// testing.record: metric `order` = a global counter taken when the stage runs. Optional
// `writes` field so tests can build conflicting graphs.
std::atomic<int> g_order{0};
class Record final : public Stage {
 public:
  explicit Record(const ParamValues& v)
      : writes_(v.string("writes")), overwrites_(v.string("overwrites")), reads_(v.string("reads")) {}
  std::vector<Access> accesses() const override {
    std::vector<Access> a;
    if (!writes_.empty()) a.push_back({writes_, Where::host, Mode::readwrite});
    if (!overwrites_.empty()) a.push_back({overwrites_, Where::host, Mode::write});
    if (!reads_.empty()) a.push_back({reads_, Where::host, Mode::read});
    return a;
  }
  Outcome run(StepContext& ctx) override {
    std::this_thread::sleep_for(std::chrono::microseconds(200));
    ctx.metrics.set("order", g_order.fetch_add(1));
    return Outcome::ok();
  }
  // Where in the same sequence the core called after_step (once the whole step ran).
  void after_step(StepContext& ctx) override { ctx.metrics.set("after", g_order.fetch_add(1)); }

 private:
  std::string writes_, overwrites_, reads_;
};

// testing.count: adds 1 to every element of the field `testing.count` (created here, f64, N)
// each time it runs. With on_demand it declares the write Access::on_demand and, when
// `announce` is set, calls ctx.will_write first, as a stage that writes only sometimes must; with
// `overwrite` as well, it reads the values first, then calls ctx.will_overwrite and writes every
// element (the snapshot swaps storage instead of copying). Metric `snapshot`: 1 when the core handed this run a rollback snapshot (its writes can be
// rolled back), else 0.
class Count final : public Stage {
 public:
  explicit Count(const ParamValues& v)
      : on_demand_(v.boolean("on_demand")), announce_(v.boolean("announce")), overwrite_(v.boolean("overwrite")) {}
  std::vector<Access> accesses() const override {
    return {{"testing.count", Where::host, Mode::readwrite, on_demand_}};
  }
  void configure(State& s) override { s.add_field("testing.count", DType::f64, 1, s.n()); }
  Outcome run(StepContext& ctx) override {
    ctx.metrics.set("snapshot", ctx.snapshot ? 1.0 : 0.0);
    Field& f = ctx.state.field("testing.count");
    if (on_demand_ && announce_ && overwrite_) {
      const std::vector<double> old(f.host<double>(), f.host<double>() + f.size());
      ctx.will_overwrite("testing.count");
      for (std::size_t i = 0; i < f.size(); ++i) f.host<double>()[i] = old[i] + 1;  // (the pointer again)
      return Outcome::ok();
    }
    if (on_demand_ && announce_) ctx.will_write("testing.count");
    for (std::size_t i = 0; i < f.size(); ++i) f.host<double>()[i] += 1;
    return Outcome::ok();
  }

 private:
  bool on_demand_, announce_, overwrite_;
};

// testing.limit_dt: reports Outcome::limit_dt(dt_max) on the listed steps (every step when the
// list is empty), writes nothing. Metrics: `attempt` and `dt` of each run, `runs` counts them.
class LimitDt final : public Stage {
 public:
  LimitDt(const ParamValues& v, const RunInfo& info)
      : active_(v.integer("rank") < 0 || v.integer("rank") == rank_of(info)),
        steps_(v.reals("steps")),
        dt_max_(v.real("dt_max")) {}
  std::vector<Access> accesses() const override { return {{fields::position, Where::host, Mode::read}}; }
  Scheduling scheduling() const override {
    Scheduling s;
    s.may_limit_dt = true;
    return s;
  }
  Outcome run(StepContext& ctx) override {
    ctx.metrics.set("attempt", ctx.host_params.attempt);
    ctx.metrics.set("dt", ctx.host_params.dt);
    ctx.metrics.set("runs", double(++runs_));
    bool listed = steps_.empty();
    for (double s : steps_) listed = listed || std::uint64_t(s) == ctx.host_params.step;
    if (!listed || !active_) return Outcome::ok();
    return Outcome::limit_dt(dt_max_, "testing.limit_dt asked for it", {2, 7});
  }

 private:
  bool active_;
  std::vector<double> steps_;
  double dt_max_;
  std::uint64_t runs_ = 0;
};

// testing.drift: moves every particle `speed` along x each step, +x for even particle ids and
// -x for odd ones, nothing else: every displacement since any step is known exactly, so a test
// can put a decomposed team's list builds and migrations on chosen steps. Decomposed (a rank
// moves its owned particles; ids are particle.id there). With edge: [a, b] (a, b > 0),
// configure (on the whole state, before a team splits it) places particles 0 and 1 at x = L/2 - a
// and L/2 + b, 2 and 3 at L - a and b, each pair on a line along x, so that they approach each
// other across the slab boundaries at L/2 and 0 of 2 or 4 slabs.
class Drift final : public Stage {
 public:
  explicit Drift(const ParamValues& v) : speed_(v.real("speed")), edge_(v.reals("edge")) {}
  std::vector<Access> accesses() const override {
    return {{fields::position, Where::host, Mode::readwrite}, {fields::image, Where::host, Mode::readwrite}};
  }
  Scheduling scheduling() const override {
    Scheduling s;
    s.team = TeamWork::decomposed;
    return s;
  }
  void configure(State& s) override {
    if (edge_.empty()) return;
    if (edge_.size() != 2 || s.n() < 4 || s.real() != DType::f64)
      throw InputError("testing.drift: edge takes [a, b], in double precision, with at least 4 particles");
    Field& pos = s.field(fields::position);
    pos.acquire(Where::host, Mode::readwrite);
    double* x = pos.host<double>();
    const int D = s.dim();
    const double L = s.box.L[0];
    const double at[4] = {0.5 * L - edge_[0], 0.5 * L + edge_[1], L - edge_[0], edge_[1]};
    for (int p = 0; p < 4; ++p) {
      x[p * D] = at[p];
      for (int k = 1; k < D; ++k) x[p * D + k] = s.box.L[k] * (p < 2 ? 0.5 : 0.25);
    }
  }
  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    double* x = s.field(fields::position).host<double>();
    std::int32_t* img = s.field(fields::image).host<std::int32_t>();
    const bool has_id = s.has_field(fields::particle_id);
    const std::uint32_t* id = has_id ? s.field(fields::particle_id).host<std::uint32_t>() : nullptr;
    const int D = s.dim();
    const double L = s.box.L[0];
    for (std::size_t i = 0; i < s.n_owned(); ++i) {
      const std::uint32_t who = id ? id[i] : std::uint32_t(i);
      double& xi = x[i * std::size_t(D)];
      xi += who % 2 == 0 ? speed_ : -speed_;
      if (xi >= L) {
        xi -= L;
        ++img[i * std::size_t(D)];
      } else if (xi < 0) {
        xi += L;
        --img[i * std::size_t(D)];
      }
    }
    return Outcome::ok();
  }

 private:
  double speed_;
  std::vector<double> edge_;
};

// testing.defer: a stage that leaves its result past the step whenever the core allows it
// (StepContext::may_defer_past_step), as overlap_correct does on CUDA. Metrics: `step`, the step
// its last settled result belongs to (set where it settles); `deferred`, 1 when this step's run
// left its result pending, else 0; `settled_in_run`, how many pending results its run() settled
// (cumulative). With fail_at ≥ 0 the result of that step reports an error when it is settled.
class Defer final : public Stage {
 public:
  explicit Defer(const ParamValues& v) : fail_at_(v.integer("fail_at")) {}
  std::vector<Access> accesses() const override { return {{fields::position, Where::host, Mode::read}}; }
  Outcome run(StepContext& ctx) override {
    if (pending_) ++settled_in_run_;
    settle_pending(ctx);
    ctx.metrics.set("settled_in_run", double(settled_in_run_));
    const bool defer = ctx.may_defer_past_step();
    ctx.metrics.set("deferred", defer ? 1.0 : 0.0);
    if (defer) {
      pending_ = true;
      pending_step_ = ctx.host_params.step;
    } else {
      read(ctx, ctx.host_params.step);
    }
    return Outcome::ok();
  }
  void settle_pending(StepContext& ctx) override {
    if (!pending_) return;
    pending_ = false;
    read(ctx, pending_step_);
  }

 private:
  void read(StepContext& ctx, std::uint64_t step) const {
    if (fail_at_ >= 0 && step == std::uint64_t(fail_at_))
      throw RunError("testing.defer: the result of step " + std::to_string(step) + " reports an error");
    ctx.metrics.set("step", double(step));
  }
  std::int64_t fail_at_;
  bool pending_ = false;
  std::uint64_t pending_step_ = 0;
  std::int64_t settled_in_run_ = 0;
};

// testing.watch (an observer): metric `seen` = what RunStats held for testing.defer/step when it
// ran (-1: nothing), so a test can check observers see the step's settled metrics.
class Watch final : public Stage {
 public:
  explicit Watch(const ParamValues&) {}
  std::vector<Access> accesses() const override { return {}; }
  Outcome run(StepContext& ctx) override {
    const auto it = ctx.stats.metrics.find("testing.defer/step");
    ctx.metrics.set("seen", it == ctx.stats.metrics.end() ? -1.0 : it->second);
    return Outcome::ok();
  }
};

bool listed(const std::vector<double>& steps, std::uint64_t step) {
  for (double s : steps)
    if (std::uint64_t(s) == step) return true;
  return false;
}

// testing.decide: a decider (Scheduling::decides_on_device), as delaunay.detect_inversion is on
// CUDA. Offered the gate it "launches" its decision (on the CPU the gate is a host word: it
// writes it in run()) and leaves the host's decision to decide(). The gate closes on the
// `closed` steps and on the `rollback` steps, where the decision (attempt 0 only) is a rollback;
// with fail_at ≥ 0 decide() throws at that step. Metrics: `gated` (1: this attempt left its
// decision to the device), `decided` (calls of decide(), cumulative).
class Decide final : public Stage {
 public:
  explicit Decide(const ParamValues& v)
      : closed_(v.reals("closed")), rollback_(v.reals("rollback")), fail_at_(v.integer("fail_at")) {}
  std::vector<Access> accesses() const override { return {{fields::position, Where::host, Mode::read}}; }
  Scheduling scheduling() const override {
    Scheduling s{true, false, false, false};
    s.decides_on_device = true;
    return s;
  }
  Outcome run(StepContext& ctx) override {
    ctx.metrics.set("gated", ctx.gate ? 1.0 : 0.0);
    ctx.metrics.set("decided", double(decided_));
    if (!ctx.gate) return outcome(ctx);
    *ctx.gate = open(ctx) ? 0u : 1u;
    ctx.gate_set = true;
    return Outcome::ok();
  }
  Decision decide(StepContext& ctx) override {
    ++decided_;
    ctx.metrics.set("decided", double(decided_));
    if (fail_at_ >= 0 && ctx.host_params.step == std::uint64_t(fail_at_))
      throw RunError("testing.decide: the decision of step " + std::to_string(fail_at_) + " reports an error");
    return {open(ctx), outcome(ctx)};
  }

 private:
  bool rolls_back(const StepContext& ctx) const {
    return ctx.host_params.attempt == 0 && listed(rollback_, ctx.host_params.step);
  }
  bool open(const StepContext& ctx) const { return !listed(closed_, ctx.host_params.step) && !rolls_back(ctx); }
  Outcome outcome(const StepContext& ctx) const {
    return rolls_back(ctx) ? Outcome::request_rollback("testing.decide asked for it") : Outcome::ok();
  }
  std::vector<double> closed_, rollback_;
  std::int64_t fail_at_;
  std::int64_t decided_ = 0;
};

// testing.follow: a follower of the gate (Scheduling::follows_gate unless follows: false), as
// delaunay.lawson and overlap_correct are on CUDA. It adds 1 to its field (`field`, f64, one
// element) per run, unless the gate it was given is closed (its "kernels" read the host word
// when it runs); on the `refuse` steps it refuses a gate; with fail_at ≥ 0 a gated run at that
// step throws. Metrics: `runs` (cumulative), `gated` (1: this run had the gate), `value` (its
// field after the run).
class Follow final : public Stage {
 public:
  explicit Follow(const ParamValues& v)
      : field_(v.string("field")),
        refuse_(v.reals("refuse")),
        follows_(v.boolean("follows")),
        fail_at_(v.integer("fail_at")) {}
  std::vector<Access> accesses() const override { return {{field_, Where::host, Mode::readwrite}}; }
  void configure(State& s) override { s.add_field(field_, DType::f64, 1, 1); }
  Scheduling scheduling() const override {
    Scheduling s;
    s.follows_gate = follows_;
    return s;
  }
  Outcome run(StepContext& ctx) override {
    ++runs_;
    ctx.metrics.set("runs", double(runs_));
    ctx.metrics.set("gated", ctx.gate ? 1.0 : 0.0);
    double& x = ctx.state.field(field_).host<double>()[0];
    if (ctx.gate && fail_at_ >= 0 && ctx.host_params.step == std::uint64_t(fail_at_))
      throw RunError("testing.follow: the gated run of step " + std::to_string(fail_at_) + " fails");
    if (ctx.gate && listed(refuse_, ctx.host_params.step)) {
      ctx.gate_refused = true;
    } else if (!ctx.gate || *ctx.gate == 0) {
      x += 1;
    }
    ctx.metrics.set("value", x);
    return Outcome::ok();
  }

 private:
  std::string field_;
  std::vector<double> refuse_;
  bool follows_;
  std::int64_t fail_at_;
  std::int64_t runs_ = 0;
};

// testing.team_tag: in a team, sums its `tag` over the ranks (Communicator::all_reduce) and
// reports metric `mismatch` = 1 unless the sum is tag x ranks, i.e. unless every rank's call
// was this stage's too. It says it splits its work (a team needs one such stage). With wait_ms it
// first sleeps on rank wait_rank, so that unordered stages would reach the reduction in another
// order on that rank.
class TeamTag final : public Stage {
 public:
  TeamTag(const ParamValues& v, const RunInfo& info)
      : tag_(v.integer("tag")), wait_rank_(v.integer("wait_rank")), wait_ms_(v.integer("wait_ms")), info_(info) {}
  std::vector<Access> accesses() const override { return {}; }
  Scheduling scheduling() const override {
    Scheduling s;
    s.team = TeamWork::split;
    return s;
  }
  Outcome run(StepContext& ctx) override {
    if (!info_.team) return Outcome::ok();
    if (info_.team->rank() == wait_rank_) std::this_thread::sleep_for(std::chrono::milliseconds(wait_ms_));
    std::int64_t sum = tag_;
    info_.team->all_reduce(&sum, 1, ReduceOp::sum);
    ctx.metrics.set("mismatch", sum == tag_ * info_.team->size() ? 0.0 : 1.0);
    return Outcome::ok();
  }

 private:
  std::int64_t tag_, wait_rank_, wait_ms_;
  RunInfo info_;
};

#ifdef FLIPFLOW_HAVE_CUDA
// The byte testing.device_fill writes on a step and testing.device_check expects.
unsigned char fill_byte(std::uint64_t step) { return static_cast<unsigned char>(step % 250 + 1); }

// testing.device_fill (CUDA): sets every byte of the device field `testing.filled` (N x f64) to
// the step's byte, queued on its stream behind a host function that holds the stream `hold_ms`
// (so any stage not ordered after it reads the last step's bytes).
class DeviceFill final : public Stage {
 public:
  explicit DeviceFill(const ParamValues& v) : hold_ms_(v.integer("hold_ms")) {}
  std::vector<Access> accesses() const override { return {{"testing.filled", Where::device, Mode::write}}; }
  void configure(State& s) override { s.add_field("testing.filled", DType::f64, 1, s.n()); }
  Outcome run(StepContext& ctx) override {
    Field& f = ctx.state.field("testing.filled");
    if (hold_ms_ > 0) {
      auto hold = [](void* ms) { std::this_thread::sleep_for(std::chrono::milliseconds(*static_cast<std::int64_t*>(ms))); };
      if (cudaLaunchHostFunc(ctx.stream, hold, &hold_ms_) != cudaSuccess) throw RunError("testing.device_fill: hold");
    }
    if (cudaMemsetAsync(f.device_raw(), fill_byte(ctx.host_params.step), f.bytes(), ctx.stream) != cudaSuccess)
      throw RunError("testing.device_fill: memset");
    return Outcome::ok();
  }

 private:
  std::int64_t hold_ms_;
};

// testing.device_check (CUDA): copies `testing.filled` from the device on its stream and counts
// the bytes that are not this step's (metric `stale`).
class DeviceCheck final : public Stage {
 public:
  explicit DeviceCheck(const ParamValues&) {}
  std::vector<Access> accesses() const override { return {{"testing.filled", Where::device, Mode::read}}; }
  Outcome run(StepContext& ctx) override {
    Field& f = ctx.state.field("testing.filled");
    std::vector<unsigned char> seen(f.bytes());
    if (cudaMemcpyAsync(seen.data(), f.device_raw(), seen.size(), cudaMemcpyDeviceToHost, ctx.stream) != cudaSuccess ||
        cudaStreamSynchronize(ctx.stream) != cudaSuccess)
      throw RunError("testing.device_check: copy");
    double stale = 0;
    for (unsigned char b : seen) stale += b != fill_byte(ctx.host_params.step);
    ctx.metrics.set("stale", stale);
    return Outcome::ok();
  }
};
#endif

template <class S>
StageFactory factory() {
  return [](const ParamValues& v, const RunInfo& info) {
    if constexpr (std::is_constructible_v<S, const ParamValues&, const RunInfo&>) return std::make_unique<S>(v, info);
    else return std::make_unique<S>(v);
  };
}

void register_testing(Registry& r) {
  r.declare({"testing.rollback", "requests rollbacks on cue (tests only)",
             {ParamSpec{"steps", ParamType::real_list, ParamValue(std::vector<double>{}), {}, {}, false, {}, "steps to fail"},
              ParamSpec::integer("fail_attempts", 1, "attempts that fail on those steps").at_least(0),
              ParamSpec::real("dt_above", 0.0, "also fail whenever dt > this (0: never)").at_least(0),
              ParamSpec::boolean("device_requests", true, "may also request from kernels on CUDA"),
              ParamSpec::boolean("scramble_undeclared", false, "also scramble `type` without declaring it"),
              ParamSpec::integer("rank", -1, "only on this rank of a team (-1: every rank; alone: rank 0)").at_least(-1)},
             {2, 3}, false});
  // rollback and count act on host fields; on CUDA too (the core keeps host and device coherent).
  r.implement("testing.rollback", Backend::cpu, factory<RequestRollback>());
  r.implement("testing.rollback", Backend::cuda, factory<RequestRollback>());
  r.declare({"testing.barrier", "waits for its partner stage (tests only)",
             {ParamSpec::integer("group", 0, "rendezvous group").at_least(0).at_most(3),
              ParamSpec::string("field", std::string(), "field to declare as read")},
             {2, 3}, false});
  r.implement("testing.barrier", Backend::cpu, factory<Barrier>());
  r.declare({"testing.record", "records the order stages ran in (tests only)",
             {ParamSpec::string("writes", std::string(), "field to declare as written"),
              ParamSpec::string("overwrites", std::string(), "field to declare as written whole (Mode::write)"),
              ParamSpec::string("reads", std::string(), "field to declare as read")},
             {2, 3}, false});
  r.implement("testing.record", Backend::cpu, factory<Record>());
  r.implement("testing.record", Backend::cuda, factory<Record>());
  r.declare({"testing.team_tag", "checks that every rank reduces this stage's tag at once (tests only)",
             {ParamSpec::integer("tag", 1, "the value each rank adds").at_least(1),
              ParamSpec::integer("wait_rank", -1, "the rank that sleeps first (-1: none)").at_least(-1),
              ParamSpec::integer("wait_ms", 0, "how long").at_least(0)},
             {2, 3}, false});
  r.implement("testing.team_tag", Backend::cpu, factory<TeamTag>());
#ifdef FLIPFLOW_HAVE_CUDA
  r.declare({"testing.device_fill", "sets testing.filled on the device, after holding its stream (tests only)",
             {ParamSpec::integer("hold_ms", 0, "how long a host function holds the stream first").at_least(0)},
             {2, 3}, false});
  r.implement("testing.device_fill", Backend::cuda, factory<DeviceFill>());
  r.declare({"testing.device_check", "counts the bytes of testing.filled that are not this step's (tests only)",
             {}, {2, 3}, false});
  r.implement("testing.device_check", Backend::cuda, factory<DeviceCheck>());
#endif
  r.declare({"testing.count", "adds 1 to the field testing.count (tests only)",
             {ParamSpec::boolean("on_demand", false, "declare the write on_demand"),
              ParamSpec::boolean("announce", true, "call will_write before writing (with on_demand)"),
              ParamSpec::boolean("overwrite", false, "announce with will_overwrite instead (with announce)")},
             {2, 3}, false});
  r.implement("testing.count", Backend::cpu, factory<Count>());
  r.declare({"testing.limit_dt", "limits Δt on cue (tests only)",
             {ParamSpec{"steps", ParamType::real_list, ParamValue(std::vector<double>{}), {}, {}, false, {},
                        "steps to limit (empty: every step)"},
              ParamSpec::real("dt_max", 1.0, "the limit reported").at_least(0),
              ParamSpec::integer("rank", -1, "only on this rank of a team (-1: every rank; alone: rank 0)").at_least(-1)},
             {2, 3}, false});
  r.implement("testing.limit_dt", Backend::cpu, factory<LimitDt>());
  r.implement("testing.limit_dt", Backend::cuda, factory<LimitDt>());
  r.implement("testing.count", Backend::cuda, factory<Count>());
  r.declare({"testing.drift", "moves particles along x at a fixed speed, even ids up, odd ids down (tests only)",
             {ParamSpec::real("speed", 0.01, "σ per step").at_least(0),
              ParamSpec{"edge", ParamType::real_list, ParamValue(std::vector<double>{}), {}, {}, false, {},
                        "[a, b]: particles 0-3 in two pairs across x = L/2 and x = 0 (empty: as they are)"}},
             {2, 3}, false});
  r.implement("testing.drift", Backend::cpu, factory<Drift>());
  r.declare({"testing.defer", "leaves its result past the step when the core allows it (tests only)",
             {ParamSpec::integer("fail_at", -1, "the step whose result reports an error (-1: none)").at_least(-1)},
             {2, 3}, false});
  r.implement("testing.defer", Backend::cpu, factory<Defer>());
  r.declare({"testing.watch", "records what an observer sees of testing.defer's metric (tests only)", {}, {2, 3}, true});
  r.implement("testing.watch", Backend::cpu, factory<Watch>());
  const auto steps = [](const char* name, const char* what) {
    return ParamSpec{name, ParamType::real_list, ParamValue(std::vector<double>{}), {}, {}, false, {}, what};
  };
  r.declare({"testing.decide", "leaves its decision to the device when the core allows it (tests only)",
             {steps("closed", "steps whose gate closes"),
              steps("rollback", "steps whose decision is a rollback (attempt 0)"),
              ParamSpec::integer("fail_at", -1, "the step whose decision throws (-1: none)").at_least(-1)},
             {2, 3}, false});
  r.implement("testing.decide", Backend::cpu, factory<Decide>());
  r.declare({"testing.follow", "adds 1 to its field unless its gate is closed (tests only)",
             {ParamSpec::string("field", std::string("testing.follow"), "the field it adds to"),
              steps("refuse", "steps on which it refuses the gate"),
              ParamSpec::boolean("follows", true, "declare Scheduling::follows_gate"),
              ParamSpec::integer("fail_at", -1, "the step whose gated run throws (-1: none)").at_least(-1)},
             {2, 3}, false});
  r.implement("testing.follow", Backend::cpu, factory<Follow>());
}

}  // namespace

FLIPFLOW_PLUGIN(register_testing)
