# Bad input to the tool, each case: exit code 2, one line on stderr naming the problem, nothing
# claimed written (tests/scripts/cli_error.cmake). No shared character needed: the built-in one
# is exported and fitted in the test's folder.
set(cli_cases
  # Argument errors (CLI11's own messages, one line instead of two).
  "frames_not_integer|play|@GLB@|--frames|3.5|--frames"
  "fps_not_number|play|@GLB@|--fps|abc|--fps"
  "rays_nan|fit|@GLB@|--rays|nan|--rays"
  "unknown_flag|play|@GLB@|--no-such-flag|--no-such-flag"
  "no_subcommand||no command given; try `skinspheres --help`"
  "missing_input|fit|input"
  # Fit settings out of range, named with the range.
  "split_rounds_zero|fit|@GLB@|--split-rounds|0|--split-rounds must be in 1..64 (got 0)"
  "split_rounds_too_many|fit|@GLB@|--split-rounds|65|--split-rounds must be in 1..64 (got 65)"
  "rays_too_few|fit|@GLB@|--rays|2|--rays must be in 3..65535 (got 2)"
  "hops_too_many|fit|@GLB@|--hops|3|--hops (contact hops) must be 0, 1 or 2 (got 3)"
  # A margin that is a search radius, not a contact distance (it asked for gigabytes at set-up).
  "margin_too_large|play|@GLB@|--frames|3|--margin|1e30|is more than 0.05 of the character's rest size"
  # Failed writes, including at the close (/dev/full fails the flush).
  "dump_full|play|@GLB@|--frames|3|--dump|/dev/full|/dev/full: write failed"
  "report_full|play|@GLB@|--frames|3|--report|/dev/full|/dev/full: write failed"
  "export_glb_full|play|@GLB@|--frames|3|--export-glb|/dev/full|/dev/full: write failed"
  "fit_output_full|fit|@GLB@|-o|@FULL_JSON@|full.json: write failed"
  "fit_output_full_binary|fit|@GLB@|-o|@FULL_SSB@|full.ssb: write failed"
  "convert_output_full|convert|@SET@|@FULL_SSB@|full.ssb: write failed"
  "convert_output_full_json|convert|@SSB@|@FULL_JSON@|full.json: write failed"
  "export_builtin_full|export-builtin|@FULL_GLB@|full.glb: write failed"
  "dump_no_dir|play|@GLB@|--frames|3|--dump|/nonexistent-dir/x.jsonl|cannot open for writing"
  # Files that are not regular files: refused at once, never read (a FIFO used to block forever,
  # /dev/zero to read until memory ran out).
  "input_fifo|fit|@FIFO@|FIFO"
  "spheres_fifo|play|@GLB@|--spheres|@FIFO@|FIFO"
  "parts_fifo|fit|@GLB@|--parts|@FIFO@|FIFO"
  "convert_input_fifo|convert|@FIFO@|@DIR@/out.ssb|FIFO"
  "convert_input_dev_zero|convert|/dev/zero|@DIR@/out.json|device"
  "input_dev_zero|fit|/dev/zero|device"
  "spheres_dev_zero|play|@GLB@|--spheres|/dev/zero|device"
  "parts_dev_zero|fit|@GLB@|--parts|/dev/zero|device"
  # Outputs that are FIFOs nobody reads: refused at once (opening one for writing used to block
  # forever, waiting for a reader).
  "fit_output_fifo|fit|@GLB@|-o|@FIFO_SSB@|fifo.ssb: is a FIFO"
  "fit_output_fifo_json|fit|@GLB@|-o|@FIFO_JSON@|fifo.json: is a FIFO"
  "convert_output_fifo|convert|@SET@|@FIFO_SSB@|fifo.ssb: is a FIFO"
  "convert_output_fifo_json|convert|@SSB@|@FIFO_JSON@|fifo.json: is a FIFO"
  "dump_fifo|play|@GLB@|--frames|3|--dump|@FIFO@|fifo: is a FIFO"
  "report_fifo|play|@GLB@|--frames|3|--report|@FIFO@|fifo: is a FIFO"
  "html_fifo|play|@GLB@|--frames|3|--html|@FIFO@|fifo: is a FIFO"
  "export_glb_fifo|play|@GLB@|--frames|3|--export-glb|@FIFO@|fifo: is a FIFO"
  "export_builtin_fifo|export-builtin|@FIFO_GLB@|fifo.glb: is a FIFO"
  # Sphere-set outputs the tool cannot tell the format of, and a truncated binary set.
  "fit_output_unknown_extension|fit|@GLB@|-o|@DIR@/set.spheres|unknown sphere-set extension"
  "fast_only_json|convert|@SET@|@DIR@/fast.json|--fast-only|--fast-only needs a binary (.ssb) output"
  "fit_fast_only_no_output|fit|@GLB@|--fast-only|--fast-only needs a binary output (-o OUT.ssb)"
  "spheres_truncated_binary|play|@GLB@|--spheres|@SHORT_SSB@|short.ssb: "
  # Clip files, joint maps and rest rigs that are not regular files; check's outputs.
  "clips_fifo|play|@GLB@|--clips|@FIFO@|FIFO"
  "joint_map_fifo|play|@GLB@|--clips|@GLB@|--joint-map|@FIFO@|FIFO"
  "joint_map_dev_zero|check|@GLB@|--clips|@GLB@|--joint-map|/dev/zero|device"
  "source_rest_fifo|play|@GLB@|--clips|@GLB@|--source-rest|@FIFO@|FIFO"
  # The retarget options are checked with or without --clips (a mistyped one was silently ignored).
  "play_retarget_no_clips|play|@GLB@|--retarget|bogus|--retarget must be auto, copy or world (got bogus)"
  "play_rest_directions_no_clips|play|@GLB@|--rest-directions|sideways|--rest-directions must be keep or match"
  "play_joint_map_no_clips|play|@GLB@|--joint-map|@FIFO@|FIFO"
  "play_source_rest_no_clips|play|@GLB@|--source-rest|@FIFO@|--source-rest: "
  "check_retarget_no_clips|check|@GLB@|--retarget|bogus|--retarget must be auto, copy or world"
  "fix_retarget_no_clips|fix|@GLB@|--retarget|bogus|-o|out.glb|--retarget must be auto, copy or world"
  "colliders_retarget_no_clips|colliders|@GLB@|--retarget|bogus|-o|c.json|--retarget must be auto, copy or world"
  "check_clips_fifo|check|@GLB@|--clips|@FIFO@|FIFO"
  "check_report_full|check|@GLB@|--clip|walk|--report|/dev/full|/dev/full: write failed"
  "check_csv_fifo|check|@GLB@|--clip|walk|--csv|@FIFO@|fifo: is a FIFO"
  "check_jobs|check|@GLB@|--jobs|-3|--jobs must be"
  "retarget_output_full|retarget|@GLB@|--clips|@GLB@|-o|@FULL_GLB@|full.glb: write failed"
  "retarget_clips_fifo|retarget|@GLB@|--clips|@FIFO@|-o|out.glb|FIFO"
  "retarget_no_clips|retarget|@GLB@|-o|out.glb|retarget needs --clips"
  "retarget_not_glb|retarget|@GLB@|--clips|@GLB@|-o|out.gltf|-o takes a .glb file"
  "fix_not_glb|fix|@GLB@|-o|out.gltf|-o takes a .glb file"
  "fix_allow_unknown|fix|@GLB@|--allow|torso:tail|-o|out.glb|--allow torso:tail: expected PART_A:PART_B"
  "fix_max_depth|fix|@GLB@|--max-depth|1.5|-o|out.glb|--max-depth must be"
  "fix_clip_unknown|fix|@GLB@|--clip|dance|-o|out.glb|--clip dance: no such clip"
  "fix_output_full|fix|@GLB@|--clip|touch|-o|@FULL_GLB@|full.glb: write failed"
  "fix_clips_fifo|fix|@GLB@|--clips|@FIFO@|-o|out.glb|FIFO"
  "fix_output_is_input|fix|@GLB@|-o|@GLB@|-o would overwrite the character file"
  "fix_report_is_output|fix|@GLB@|-o|out.glb|--report|out.glb|--report and -o name the same file"
  "fix_report_no_folder|fix|@GLB@|-o|out.glb|--report|nodir/r.json|--report: no folder"
  "colliders_format|colliders|@GLB@|--format|fbx|-o|out.json|--format: 'fbx' is not one of"
  "colliders_budget|colliders|@GLB@|--budget|0|-o|out.json|--budget: must be between 1 and 1024 (got 0)"
  "colliders_vrm0_capsules|colliders|@GLB@|--format|vrm0|--shapes|capsules|-o|out.glb|--format vrm0 holds spheres only"
  "colliders_extension|colliders|@GLB@|--format|usd|-o|out.json|-o: --format usd writes a .usda file"
  "colliders_output_is_input|colliders|@GLB@|--format|vrm1|-o|@GLB@|-o would overwrite the character file"
  "colliders_no_folder|colliders|@GLB@|-o|nodir/c.json|-o: no folder"
  "colliders_report_is_output|colliders|@GLB@|-o|c.json|--report|c.json|--report and -o name the same file"
  "colliders_clip_unknown|colliders|@GLB@|--clip|dance|-o|c.json|--clip dance: no such clip"
  "colliders_output_full|colliders|@GLB@|--fps|5|--budget|4|-o|@FULL_JSON@|full.json: write failed"
  # A sphere set nested 100,000 deep (it crashed play with SIGSEGV).
  "spheres_deep|play|@GLB@|--spheres|@DEEP@|nests 100002 deep"
)
foreach(case ${cli_cases})
  string(REPLACE "|" ";" fields "${case}")
  list(GET fields 0 name)
  list(GET fields -1 needle)
  list(REMOVE_AT fields 0 -1)
  string(REPLACE ";" "|" args "${fields}")
  add_test(NAME tool.cli_error.${name}
    COMMAND ${CMAKE_COMMAND} -DTOOL=$<TARGET_FILE:skinspheres> "-DARGS=${args}" "-DNEEDLE=${needle}"
            -DDIR=${PROJECT_BINARY_DIR}/test_tmp/cli_error_${name} -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/cli_error.cmake)
  set_tests_properties(tool.cli_error.${name} PROPERTIES TIMEOUT 300)
endforeach()
