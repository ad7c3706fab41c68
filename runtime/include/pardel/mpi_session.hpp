/**
 * @file mpi_session.hpp
 * The process's MPI session. MPI is optional at build time (PARDEL_WITH_MPI) and at run time:
 * MPI is initialized only when the process was started by an MPI launcher (mpirun, mpiexec,
 * srun), so plain runs never touch it. Without MPI every query answers as one rank of one.
 */
#ifndef PARDEL_MPI_SESSION_HPP
#define PARDEL_MPI_SESSION_HPP

namespace pardel::mpi {

/** Whether this build was compiled with MPI. */
bool built_with_mpi();

/** Whether the environment says an MPI launcher started this process. */
bool launched_by_mpi();

/**
 * Initializes MPI (thread level funneled: OpenMP inside a rank, MPI calls from its main thread)
 * when the build has MPI and a launcher started the process; finalizes it on destruction.
 * One per process, constructed at the top of main().
 */
class Session {
 public:
  Session(int* argc, char*** argv);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  /** The session of this process (nullptr before one was constructed). */
  static const Session* current();

  bool active() const { return active_; }  ///< MPI was initialized by this session
  int rank() const { return rank_; }       ///< 0 when not active
  int size() const { return size_; }       ///< 1 when not active

 private:
  bool active_ = false;
  int rank_ = 0;
  int size_ = 1;
};

/** The rank and size of the current session (0 and 1 without one). */
int world_rank();
int world_size();

/**
 * Ends the whole job with exit status `code`: MPI_Abort on every rank when a session is active
 * with more than one rank (a rank that returned from main alone would leave the others waiting in
 * a collective call forever), std::exit otherwise. Output written to stderr before is kept.
 */
[[noreturn]] void abort_job(int code);

}  // namespace pardel::mpi

#endif  // PARDEL_MPI_SESSION_HPP
