// gtest main for the deal.II-backed tests: MPI/PETSc live for the whole run.
#include <gtest/gtest.h>

#include "fem.hpp"

int main(int argc, char** argv) {
  demfem::continuum::fem::MpiScope mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  if (demfem::continuum::fem::MpiScope::rank() != 0) {
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  return RUN_ALL_TESTS();
}
