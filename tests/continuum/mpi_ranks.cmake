# 1 rank vs 2 ranks: the same scene must give the same probes (distributed PETSc vectors; the
# explicit integrator's per-rank cells and force reduction).
# -DFILES=a.csv,b.csv (default structures.csv,surface_profile.csv) are compared with compare_csv at
# relative tolerance -DTOL (default 1e-7, per column: relative to the column's largest value).
# -DEXPECT=regex: the 2-rank run's continuum/log.txt must match it (e.g. that it split the cells).
# -DRERUN=1: the 2-rank run goes twice into the same directory (the second clears the first's
# outputs: only the first rank may clear them; two clearing at once failed with exit 1).
# When mpirun cannot start 2 processes here, it prints MPI_UNUSABLE_SKIP (the test's
# SKIP_REGULAR_EXPRESSION) and passes as skipped.
if(NOT FILES)
  set(FILES structures.csv,surface_profile.csv)
endif()
string(REPLACE "," ";" FILES "${FILES}")
if(NOT TOL)
  set(TOL 1e-7)
endif()
set(MPIRUN ${MPIEXEC} --allow-run-as-root --oversubscribe -np 2)
execute_process(COMMAND ${MPIRUN} ${CMAKE_COMMAND} -E true RESULT_VARIABLE r0 OUTPUT_QUIET
                ERROR_VARIABLE e0)
if(NOT r0 EQUAL 0)
  message("MPI_UNUSABLE_SKIP: `${MPIEXEC} -np 2` cannot start here: ${e0}")
  return()
endif()
# Fresh run directories: an earlier build's results of an older scene version are refused.
file(REMOVE_RECURSE ${OUT}/np1 ${OUT}/np2)
execute_process(COMMAND ${DEMFEM} run ${SCENE} --solver continuum --out ${OUT}/np1
                RESULT_VARIABLE r1 OUTPUT_QUIET)
if(NOT r1 EQUAL 0)
  message(FATAL_ERROR "1-rank run failed: ${r1}")
endif()
execute_process(COMMAND ${MPIRUN} ${DEMFEM} run ${SCENE} --solver continuum --out ${OUT}/np2
                RESULT_VARIABLE r2 OUTPUT_QUIET)
if(NOT r2 EQUAL 0)
  message(FATAL_ERROR "2-rank run failed: ${r2}")
endif()
if(RERUN)
  execute_process(COMMAND ${MPIRUN} ${DEMFEM} run ${SCENE} --solver continuum --out ${OUT}/np2
                  RESULT_VARIABLE r3 OUTPUT_QUIET ERROR_VARIABLE e3)
  if(NOT r3 EQUAL 0)
    message(FATAL_ERROR "2-rank re-run into the used directory failed: ${r3}: ${e3}")
  endif()
endif()
if(NOT EXISTS ${OUT}/np2/continuum/continuum_0000.1.vtu)
  message(FATAL_ERROR "the 2-rank run did not write a second partition")
endif()
if(EXPECT)
  file(READ ${OUT}/np2/continuum/log.txt log2)
  if(NOT log2 MATCHES "${EXPECT}")
    message(FATAL_ERROR "the 2-rank run's log does not match '${EXPECT}'")
  endif()
endif()
foreach(f ${FILES})
  execute_process(COMMAND ${COMPARE} ${OUT}/np1/continuum/${f} ${OUT}/np2/continuum/${f} ${TOL}
                  RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${f} differs between 1 and 2 ranks")
  endif()
endforeach()
