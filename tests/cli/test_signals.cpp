// Tests of the command line's record of SIGINT and SIGTERM (cli/signals.hpp).
#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>

#include "signals.hpp"

namespace {

using namespace pardel::cli;

TEST(CatchSignals, RecordsTheFirstSignalInsteadOfEndingTheProcess) {
  CatchSignals catch_signals;
  EXPECT_FALSE(interrupted().load());
  EXPECT_EQ(caught_signal(), 0);
  std::raise(SIGTERM);
  std::raise(SIGINT);
  EXPECT_TRUE(interrupted().load());
  EXPECT_EQ(caught_signal(), SIGTERM);
  EXPECT_EQ(signal_name(caught_signal()), "SIGTERM");
}

TEST(CatchSignals, AnInnerScopeStartsCleanAndLeavesTheOuterRecord) {
  CatchSignals outer;
  std::raise(SIGINT);
  {
    CatchSignals inner;  // a plot step after an interrupted solve
    EXPECT_FALSE(interrupted().load());
    EXPECT_EQ(caught_signal(), 0);
  }
  EXPECT_TRUE(interrupted().load());
  EXPECT_EQ(caught_signal(), SIGINT);
  {
    CatchSignals inner;
    std::raise(SIGTERM);
    EXPECT_EQ(caught_signal(), SIGTERM);
  }
  EXPECT_EQ(caught_signal(), SIGTERM);  // the later signal is the one on record
}

TEST(CatchSignals, RestorePutsThePreviousActionBack) {
  struct sigaction ignore {};
  ignore.sa_handler = SIG_IGN;
  sigemptyset(&ignore.sa_mask);
  struct sigaction before {};
  ASSERT_EQ(::sigaction(SIGTERM, &ignore, &before), 0);
  {
    CatchSignals catch_signals;
    struct sigaction during {};
    ::sigaction(SIGTERM, nullptr, &during);
    EXPECT_NE(during.sa_handler, SIG_IGN);
    catch_signals.restore();
    struct sigaction after {};
    ::sigaction(SIGTERM, nullptr, &after);
    EXPECT_EQ(after.sa_handler, SIG_IGN);
  }
  ::sigaction(SIGTERM, &before, nullptr);
  EXPECT_EQ(signal_name(0), "");
  EXPECT_EQ(signal_name(SIGINT), "SIGINT (Ctrl-C)");
}

TEST(CatchSignals, UnderEndsProcessTheSameSignalAgainTakesItsUsualEffect) {
  // pardel check polls only between long steps: its first Ctrl-C is recorded, a second one ends it.
  EXPECT_EXIT(
      {
        CatchSignals catch_signals(CatchSignals::Again::ends_process);
        std::raise(SIGINT);
        if (!interrupted().load() || caught_signal() != SIGINT) std::_Exit(3);
        std::raise(SIGINT);
        std::_Exit(0);
      },
      ::testing::KilledBySignal(SIGINT), "");
  // By default it is only recorded.
  EXPECT_EXIT(
      {
        CatchSignals catch_signals;
        std::raise(SIGINT);
        std::raise(SIGINT);
        std::_Exit(interrupted().load() ? 0 : 3);
      },
      ::testing::ExitedWithCode(0), "");
}

}  // namespace
