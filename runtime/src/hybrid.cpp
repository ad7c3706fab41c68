/**
 * @file hybrid.cpp
 * Jacobi-Newton sweeps until the Hessian of the action is positive definite at the iterate
 * (checked every few sweeps by the factorization of the whole-system Newton it then switches to),
 * then that globalized Newton: the same class in one process and over MPI ranks, whose Newton
 * (the topology's, topology.hpp) factors the Hessian by block LDL^T or cyclic reduction in one
 * process and by the Schur-complement split over ranks.
 */
#include "engine.hpp"
#include "iteration.hpp"

namespace pardel::detail {
namespace {

class Hybrid final : public Method_ {
 public:
  Hybrid(const Options& o, int dim, Partition& partition, std::unique_ptr<Method_> newton)
      : partition_(partition), sweeps_(make_jacobi_newton(o, dim)), newton_(std::move(newton)) {}

  void reset(Context& ctx) override {
    sweeps_->reset(ctx);
    newton_->reset(ctx);
    newton_mode_ = false;
    since_check_ = check_every;
  }

  int evaluate(Context& ctx) override { return newton_mode_ ? newton_->evaluate(ctx) : sweeps_->evaluate(ctx); }

  StepOutcome iterate(Context& ctx, long iteration) override {
    if (!newton_mode_ && ++since_check_ >= check_every) {
      since_check_ = 0;
      // Newton's full evaluation (residual and action over all processes), which its first step reads.
      eval_full(ctx, ctx.q);
      partition_.agree_on_residual(ctx, newton_->evaluate(ctx));
      newton_mode_ = newton_->hessian_positive_definite(ctx);
    }
    return newton_mode_ ? newton_->iterate(ctx, iteration) : sweeps_->iterate(ctx, iteration);
  }

  bool accept_stop(Context& ctx, bool final_level) override {
    return newton_mode_ ? newton_->accept_stop(ctx, final_level) : true;
  }
  void times_changed() override { newton_->times_changed(); }
  double level_assessment_seconds() const override { return newton_->level_assessment_seconds(); }
  bool newton_correction(Context& ctx, std::vector<double>& delta) override {
    return newton_mode_ && newton_->newton_correction(ctx, delta);
  }

  /** {phase (0 sweeps, 1 newton), sweeps since the last check, then Newton's state}. Collective. */
  std::vector<double> save_state() const override {
    std::vector<double> state = {newton_mode_ ? 1.0 : 0.0, static_cast<double>(since_check_)};
    const std::vector<double> newton = newton_->save_state();
    state.insert(state.end(), newton.begin(), newton.end());
    return state;
  }
  bool load_state(const std::vector<double>& state) override {
    if (state.size() < 2 || (state[0] != 0 && state[0] != 1) || !(state[1] >= 0 && state[1] <= check_every))
      return false;
    if (!newton_->load_state(std::vector<double>(state.begin() + 2, state.end()))) return false;
    newton_mode_ = state[0] == 1;
    since_check_ = static_cast<int>(state[1]);
    return true;
  }

 private:
  static constexpr int check_every = 10;
  Partition& partition_;
  std::unique_ptr<Method_> sweeps_, newton_;
  bool newton_mode_ = false;
  int since_check_ = 0;
};

}  // namespace

std::unique_ptr<Method_> make_hybrid(const Options& options, int dim, Partition& partition,
                                     std::unique_ptr<Method_> newton) {
  return std::make_unique<Hybrid>(options, dim, partition, std::move(newton));
}

}  // namespace pardel::detail
