# An explicit continuum run on 2 MPI ranks stopped by SIGTERM writes one checkpoint per rank; `--resume` on 2 ranks ends with the files of an
# uninterrupted 2-rank run, byte for byte (steps.csv and the VTK files, which hold wall times and
# dates, excepted), and a resume on 1 rank is refused with exit 2.
# -DSCENE: tests/continuum/mpi_explicit.toml, run here on a coarser mesh with 480 steps.
# When mpirun cannot start 2 processes here, it prints MPI_UNUSABLE_SKIP (the test's
# SKIP_REGULAR_EXPRESSION) and passes as skipped.
set(MPIRUN ${MPIEXEC} --allow-run-as-root --oversubscribe -np 2)
execute_process(COMMAND ${MPIRUN} ${CMAKE_COMMAND} -E true RESULT_VARIABLE r0 OUTPUT_QUIET
                ERROR_VARIABLE e0)
if(NOT r0 EQUAL 0)
  message("MPI_UNUSABLE_SKIP: `${MPIEXEC} -np 2` cannot start here: ${e0}")
  return()
endif()
file(REMOVE_RECURSE ${OUT})
file(MAKE_DIRECTORY ${OUT})
file(READ ${SCENE} text)
string(REGEX REPLACE "\nduration = [^\n]*" "\nduration = 1.2" text "${text}")
string(REGEX REPLACE "\nrefinement = [^\n]*" "\nrefinement = 1" text "${text}")
string(REGEX REPLACE "\ninterval = [^\n]*" "\ninterval = 0.1" text "${text}")
string(REGEX REPLACE "\nprobe_interval = [^\n]*" "\nprobe_interval = 0.0025" text "${text}")
file(WRITE ${OUT}/scene.toml "${text}")

execute_process(COMMAND ${MPIRUN} ${DEMFEM} run ${OUT}/scene.toml --solver continuum --out
                        ${OUT}/whole RESULT_VARIABLE r1 OUTPUT_QUIET ERROR_QUIET)
if(NOT r1 EQUAL 0)
  message(FATAL_ERROR "the uninterrupted 2-rank run failed: ${r1}")
endif()
# SIGTERM to both ranks (mpirun's children), as a batch scheduler sends it to every process of a
# job, once 5 steps are on the disk (steps.csv: a header and one flushed row per step)
string(REPLACE ";" " " MPIRUN_SH "${MPIRUN}")
execute_process(
  COMMAND
    sh -c "${MPIRUN_SH} ${DEMFEM} run ${OUT}/scene.toml --solver continuum --out ${OUT}/cut \
> ${OUT}/cut.log 2>&1 & p=$!; \
while kill -0 $p 2>/dev/null; do \
  s=$(wc -l < ${OUT}/cut/continuum/steps.csv 2>/dev/null || echo 0); \
  if [ \"$s\" -gt 5 ]; then kill -TERM $(pgrep -P $p); break; fi; sleep 0.01; done; wait $p"
  RESULT_VARIABLE r2)
file(READ ${OUT}/cut.log log2)
if(NOT log2 MATCHES "stopped by SIGTERM")
  message(FATAL_ERROR "the 2-rank run was not stopped (exit ${r2}):\n${log2}")
endif()
foreach(f checkpoint.ckpt checkpoint.1.ckpt)
  if(NOT EXISTS ${OUT}/cut/continuum/${f})
    message(FATAL_ERROR "no ${f} after the stop:\n${log2}")
  endif()
endforeach()
execute_process(COMMAND ${DEMFEM} run ${OUT}/scene.toml --solver continuum --out ${OUT}/cut
                        --resume RESULT_VARIABLE r3 OUTPUT_QUIET ERROR_VARIABLE e3)
if(NOT r3 EQUAL 2 OR NOT e3 MATCHES "mpi_ranks = 1' here, 'mpi_ranks = 2' in the checkpoint")
  message(FATAL_ERROR "a 1-rank resume of a 2-rank checkpoint was not refused (exit ${r3}):\n${e3}")
endif()
execute_process(COMMAND ${MPIRUN} ${DEMFEM} run ${OUT}/scene.toml --solver continuum --out
                        ${OUT}/cut --resume RESULT_VARIABLE r4 OUTPUT_QUIET ERROR_VARIABLE e4)
if(NOT r4 EQUAL 0)
  message(FATAL_ERROR "the 2-rank resume failed: ${r4}:\n${e4}")
endif()
file(READ ${OUT}/cut/continuum/log.txt log4)
if(NOT log4 MATCHES "resumed from .* at t = ")
  message(FATAL_ERROR "the 2-rank resume did not resume:\n${log4}")
endif()
foreach(f structures.csv walls.csv surface_profile.csv)
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT}/whole/continuum/${f}
                          ${OUT}/cut/continuum/${f} RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${f} of the resumed 2-rank run differs from the uninterrupted run's")
  endif()
endforeach()
