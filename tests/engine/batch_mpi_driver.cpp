// For batch_mpi_test: a batch of 4 sheets whose sheets 2 and 3 fail as they start (Poisson's ratio spread
// 0.3 → 0.7 past its limit 0.5, which `papertear batch` would refuse before running any), run on the ranks
// of the job it is started in (one without mpirun); rank 0 writes batch.json to OUT.
// Usage: batch_mpi_driver SCENARIO OUT
#include "engine/batch_mpi.hpp"

#include <cstdio>
#include <exception>

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: batch_mpi_driver SCENARIO OUT\n");
    return 2;
  }
  try {
    pt::BatchMpi mpi;
    const pt::Scenario base = pt::load_scenario(argv[1]);
    pt::BatchOptions options;
    options.sheets = 4;
    options.threads = 1;
    options.frames = 3;
    options.vary = {pt::parse_variation("material.poisson=0.3:0.7")};
    const pt::BatchOnRanks job = pt::run_batch_on_ranks(mpi.ranks(), base, options);
    if (mpi.ranks().rank == 0) pt::write_batch_json(job.result, base.name, argv[2]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "batch_mpi_driver: %s\n", e.what());
    return 1;
  }
  return 0;
}
