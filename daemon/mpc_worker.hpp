#pragma once
// An mpc instance's optimiser thread (lagranged-mpc), as MJPC's planner runs
// beside its physics: it owns a planner (controllers/mpc.hpp: the controller's
// immutable DdpModel, shared, and a DdpData of its own), takes the latest
// state the tick offers (InstanceChannels::mpc_state), solves from it no more
// often than every replan_period of the instance's time, and publishes each
// solve's policy (InstanceChannels::mpc_plans), with the solve's wall-clock
// time (MpcPolicy::solve_time, for <NAME>_MPC). Each solve models the
// effects the state carries (an `effect` command switched: MpcPlanner::FollowEffects). Both mailboxes are
// latest-wins triple buffers built before the loop: neither side allocates,
// blocks or waits for the other. The tick never plans.
//
// Stop() ends the thread within one knot's work of a solve: the stop flag is
// polled at every knot of every pass (DdpData::stop) and between solves.

#include <atomic>
#include <cstdint>
#include <memory>
#include <thread>

#include "controllers/mpc.hpp"
#include "daemon/runtime.hpp"

namespace lagrange {

class MpcWorker {
 public:
  // `replan_period` s between solves (> 0: MpcController::replan_period);
  // `channels` (the instance's) must outlive the worker.
  MpcWorker(std::shared_ptr<const DdpModel> model, double replan_period, InstanceChannels& channels);
  ~MpcWorker();  // Stop()
  MpcWorker(const MpcWorker&) = delete;
  MpcWorker& operator=(const MpcWorker&) = delete;

  void Start();  // the thread, once
  void Stop();   // sets the flag and joins; idempotent

  // One pass of the thread's loop, for tests that drive it on their own
  // thread: takes the latest state and plans from it when it is due; true
  // when it published a plan.
  bool PlanOnce();
  std::int64_t solves() const { return solves_.load(std::memory_order_relaxed); }

  // Test hook: a solve that never finishes (the thread waits in it until
  // stopped), so that a stalled optimiser and a stop during a solve can be tested.
  void StallForTest() { stall_.store(true, std::memory_order_relaxed); }

 private:
  void Run();

  MpcPlanner planner_;
  double replan_period_;
  InstanceChannels& channels_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> stall_{false};
  std::atomic<std::int64_t> solves_{0};
  bool planned_ = false;
  double last_t_ = 0.0;
  std::thread thread_;
};

// The workers of every mpc instance of `runtime` (none: empty), not started.
std::vector<std::unique_ptr<MpcWorker>> MakeMpcWorkers(Runtime& runtime);

}  // namespace lagrange
