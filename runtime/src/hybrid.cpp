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
