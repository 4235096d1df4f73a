#pragma once
// Bumped whenever Stage, StepContext, Registry or State change layout: a plugin built against
// another value is refused at load time instead of crashing.
#define FF_ABI_VERSION 9  // 9: RunStats::metric_stamps; 8: RunInfo::messages, StageDecl::needs_before; 7: Stage::decide, StepContext::gate, Scheduling::decides_on_device/follows_gate; 6: Stage::settle_pending, StepContext::may_defer_past_step; 5: GhostExchange::request_band, Scheduling::refreshes_ghosts/fills_gap; 3: RunInfo::team, Scheduling::team (issue 21); 4: State::n_owned, particle fields, TeamWork::decomposed/local
#define FF_VERSION_STRING "0.1.0"
