// The process's MPI session: initializes MPI only under an MPI launcher, and only in MPI builds.
#include "pardel/mpi_session.hpp"

#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#ifdef PARDEL_HAVE_MPI
#include <mpi.h>
#endif

namespace pardel::mpi {

namespace {
const Session* g_current = nullptr;
}

bool built_with_mpi() {
#ifdef PARDEL_HAVE_MPI
  return true;
#else
  return false;
#endif
}

bool launched_by_mpi() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE", "PMI_RANK", "MPI_LOCALNRANKS"}) {
    if (std::getenv(name) != nullptr) return true;
  }
  return false;
}

Session::Session(int* argc, char*** argv) {
  if (g_current != nullptr) throw std::logic_error("pardel::mpi::Session: one session per process");
#ifdef PARDEL_HAVE_MPI
  if (launched_by_mpi()) {
    int initialized = 0;
    MPI_Initialized(&initialized);
    if (!initialized) {
      int provided = 0;
      MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
      active_ = true;
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
#else
  (void)argc;
  (void)argv;
#endif
  g_current = this;
}

Session::~Session() {
#ifdef PARDEL_HAVE_MPI
  if (active_) {
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (!finalized) MPI_Finalize();
  }
#endif
  g_current = nullptr;
}

const Session* Session::current() { return g_current; }

int world_rank() { return g_current ? g_current->rank() : 0; }
int world_size() { return g_current ? g_current->size() : 1; }

void abort_job(int code) {
  std::fflush(stdout);
  std::fflush(stderr);
#ifdef PARDEL_HAVE_MPI
  if (g_current != nullptr && g_current->active() && g_current->size() > 1) MPI_Abort(MPI_COMM_WORLD, code);
#endif
  std::exit(code);
}

}  // namespace pardel::mpi
