#include "daemon/mpc_worker.hpp"

#include <pthread.h>

#include <chrono>

namespace lagrange {

MpcWorker::MpcWorker(std::shared_ptr<const DdpModel> model, double replan_period, InstanceChannels& channels)
    : planner_(std::move(model)),
      replan_period_(replan_period),
      channels_(channels) {}

MpcWorker::~MpcWorker() { Stop(); }

void MpcWorker::Start() {
  if (thread_.joinable()) return;
  thread_ = std::thread([this] { Run(); });
  pthread_setname_np(thread_.native_handle(), "lagranged-mpc");
}

void MpcWorker::Stop() {
  stop_.store(true, std::memory_order_relaxed);
  if (thread_.joinable()) thread_.join();
}

bool MpcWorker::PlanOnce() {
  const MpcStateMessage* state = channels_.mpc_state.Take();
  if (state == nullptr) return false;
  // Due every replan_period of the instance's time; at once after a reset (its time went back).
  if (planned_ && state->t >= last_t_ && state->t < last_t_ + replan_period_ - 1e-9) return false;
  while (stall_.load(std::memory_order_relaxed) && !stop_.load(std::memory_order_relaxed)) {
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  if (stop_.load(std::memory_order_relaxed)) return false;
  MpcPolicy& plan = channels_.mpc_plans.back();
  const auto began = std::chrono::steady_clock::now();
  planner_.FollowEffects(state->effects);
  planner_.Plan(state->t, state->q, state->qd, state->q_ref, state->qd_ref, plan, &stop_, &state->pose);
  plan.solve_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
  if (stop_.load(std::memory_order_relaxed)) return false;  // a solve cut short is not handed over
  channels_.mpc_plans.Publish();
  planned_ = true;
  last_t_ = state->t;
  solves_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

// Solves whenever a due state is there; otherwise sleeps a tenth of a
// millisecond (this thread is not the tick's: it may sleep).
void MpcWorker::Run() {
  while (!stop_.load(std::memory_order_relaxed)) {
    if (!PlanOnce()) std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
}

std::vector<std::unique_ptr<MpcWorker>> MakeMpcWorkers(Runtime& runtime) {
  std::vector<std::unique_ptr<MpcWorker>> workers;
  for (std::size_t i = 0; i < runtime.size(); ++i) {
    Instance& inst = runtime.instance(i);
    const InstanceModel& m = runtime.model().instances[i];
    for (std::size_t k = 0; k < m.controllers.size(); ++k) {
      if (const MpcController* c = inst.mpc_controller(k)) {
        workers.push_back(std::make_unique<MpcWorker>(c->ddp_model(), c->replan_period(), runtime.channels(i)));
      }
    }
  }
  return workers;
}

}  // namespace lagrange
