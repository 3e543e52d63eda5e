# The data of the example programs' and the Python module's tests (tests/CMakeLists.txt,
# fixture examples_data), made with the CLI in a few seconds:
#   cmake -DBSDFMIX=<bsdfmix> -DOUT=<dir> -P tests/examples_data.cmake
# - table.h5: a small silk fiber table, 6 theta_o slices of 32 x 64 cells, with rgb;
# - mixture.h5: fitted at theta_o slices 1 and 4 alone (fit.theta_o at their centers), so
#   slices 2 and 3 are blended between them and 0 and 5 clamped to them; padded storage;
# - mixture_ragged.h5: the same packed ragged with float32 colour (pack's default);
# - compare.csv, compare_ragged.csv: `bsdfmix compare` of each against the table;
# - samples.csv: `bsdfmix sample --cpu` of mixture.h5 at theta_o 0.3, phi_o 1.1, seed 7;
# - mixture_displace.h5 (padded, interpolation displace), its compare_displace.csv and
#   samples_displace.csv as above.
foreach(v BSDFMIX OUT)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "examples_data.cmake: -D${v}=... is required")
  endif()
endforeach()
file(REMOVE_RECURSE ${OUT})
file(MAKE_DIRECTORY ${OUT})
file(WRITE ${OUT}/fit.yaml "table: ${OUT}/table.h5
generate:
  preset: silk
  theta_o: 6
  theta_i: 32
  phi_i: 64
fit:
  output: ${OUT}/mixture.h5
  report: ${OUT}/fit.csv
  search_report: ${OUT}/search.csv
  k_min: 1
  k_max: 6
  restarts: 1
  final_restarts: 2
  theta_o: [-0.7853981633974483, 0.7853981633974483]
")

function(run)
  execute_process(COMMAND ${ARGN} WORKING_DIRECTORY ${OUT} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    string(REPLACE ";" " " cmd "${ARGN}")
    message(FATAL_ERROR "examples_data: `${cmd}` failed (${rc}):\n${out}${err}")
  endif()
endfunction()

run(${BSDFMIX} fit -q ${OUT}/fit.yaml)
run(${BSDFMIX} pack -q ${OUT}/mixture.h5 -o ${OUT}/mixture_ragged.h5)
run(${BSDFMIX} compare -q ${OUT}/mixture.h5 ${OUT}/table.h5 --csv ${OUT}/compare.csv)
run(${BSDFMIX} compare -q ${OUT}/mixture_ragged.h5 ${OUT}/table.h5 --csv ${OUT}/compare_ragged.csv)
run(${BSDFMIX} sample -q --cpu ${OUT}/mixture.h5 --theta-o 0.3 --phi-o 1.1 -n 2000 --seed 7 -o ${OUT}/samples.csv)
run(${BSDFMIX} pack -q ${OUT}/mixture.h5 --storage padded --interpolation displace -o ${OUT}/mixture_displace.h5)
run(${BSDFMIX} compare -q ${OUT}/mixture_displace.h5 ${OUT}/table.h5 --csv ${OUT}/compare_displace.csv)
run(${BSDFMIX} sample -q --cpu ${OUT}/mixture_displace.h5 --theta-o 0.3 --phi-o 1.1 -n 2000 --seed 7
    -o ${OUT}/samples_displace.csv)
message(STATUS "examples_data: table, mixtures, compare and sample CSVs in ${OUT}")
