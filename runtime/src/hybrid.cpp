/**
 * @file hybrid.cpp
 * Jacobi-Newton sweeps until the Hessian of the action is positive definite at the iterate
 * (checked every few sweeps by the block LDL^T of the certificate), then globalized Newton.
 */
#include "block_tridiagonal.hpp"
#include "engine.hpp"

namespace pardel::detail {
namespace {

template <int D>
class Hybrid : public Method_ {
 public:
  explicit Hybrid(const Options& o) : sweeps_(make_jacobi_newton(o, D < 0 ? 9 : D)), newton_(make_newton(o, D < 0 ? 9 : D)) {}

  void reset(Context& ctx) override {
    sweeps_->reset(ctx);
    newton_->reset(ctx);
    H_.resize(ctx.N, ctx.dim);
    newton_mode_ = false;
    since_check_ = check_every;
  }

  int evaluate(Context& ctx) override { return newton_mode_ ? newton_->evaluate(ctx) : sweeps_->evaluate(ctx); }

  StepOutcome iterate(Context& ctx, long iteration) override {
    if (!newton_mode_ && ++since_check_ >= check_every) {
      since_check_ = 0;
      eval_full(ctx, ctx.q);
      compute_residual(ctx);
      ctx.action = sum_action(ctx);
      ctx.action_known = true;
      H_.assemble(ctx, 0.0);
      newton_mode_ = H_.factor_ldlt();
    }
    return newton_mode_ ? newton_->iterate(ctx, iteration) : sweeps_->iterate(ctx, iteration);
  }

  bool accept_stop(Context& ctx, bool final_level) override {
    return newton_mode_ ? newton_->accept_stop(ctx, final_level) : true;
  }
  void times_changed() override { newton_->times_changed(); }

  /** {phase (0 sweeps, 1 newton), sweeps since the last check, then Newton's state}. */
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
  std::unique_ptr<Method_> sweeps_, newton_;
  BlockTridiagonal<D> H_;
  bool newton_mode_ = false;
  int since_check_ = 0;
};

}  // namespace

std::unique_ptr<Method_> make_hybrid(const Options& options, int dim) {
  return dispatch_dim(dim, [&](auto D) -> std::unique_ptr<Method_> {
    return std::make_unique<Hybrid<decltype(D)::value>>(options);
  });
}

}  // namespace pardel::detail
