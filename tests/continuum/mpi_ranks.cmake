# 1 rank vs 2 ranks: the same scene must give the same probes (distributed PETSc vectors).
# Fresh run directories: an earlier build's results of an older scene version are refused.
file(REMOVE_RECURSE ${OUT}/np1 ${OUT}/np2)
execute_process(COMMAND ${DEMFEM} run ${SCENE} --solver continuum --out ${OUT}/np1
                RESULT_VARIABLE r1 OUTPUT_QUIET)
if(NOT r1 EQUAL 0)
  message(FATAL_ERROR "1-rank run failed: ${r1}")
endif()
execute_process(COMMAND ${MPIEXEC} --allow-run-as-root --oversubscribe -np 2 ${DEMFEM} run ${SCENE}
                        --solver continuum --out ${OUT}/np2
                RESULT_VARIABLE r2 OUTPUT_QUIET)
if(NOT r2 EQUAL 0)
  message(FATAL_ERROR "2-rank run failed: ${r2}")
endif()
if(NOT EXISTS ${OUT}/np2/continuum/continuum_0000.1.vtu)
  message(FATAL_ERROR "the 2-rank run did not write a second partition")
endif()
foreach(f structures.csv surface_profile.csv)
  execute_process(COMMAND ${COMPARE} ${OUT}/np1/continuum/${f} ${OUT}/np2/continuum/${f} 1e-7
                  RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${f} differs between 1 and 2 ranks")
  endif()
endforeach()
