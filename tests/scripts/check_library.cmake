# skinspheres check on a library made by export-builtin (no shared character needed), and the
# retargeting options' bad input:
#  - exit codes: the touch clip penetrates (1), the walk does not (0);
#  - a broken and an empty file among good ones: each reported in one line on stderr and skipped,
#    the others checked, exit 2; the JSON and CSV reports say the same;
#  - the built-in character's clips from rigs with other rest frames (and bones 1.3 times as long)
#    give the contacts of its own clips: the same part pairs, frames and depths;
#  - one worker and two give the same report;
#  - hostile joint maps, --source-rest and --retarget values: exit 2, one line naming the problem;
#    a --source-rest frame past a clip's end refused, one that is not a rest pose warned about.
#   cmake -DTOOL=... -DDIR=... -P check_library.cmake
file(REMOVE_RECURSE ${DIR})
file(MAKE_DIRECTORY ${DIR}/lib)

include(${CMAKE_CURRENT_LIST_DIR}/tool_checks.cmake)

expect_exit(0 "wrote" export-builtin ${DIR}/builtin.glb)
expect_exit(0 "wrote" export-builtin ${DIR}/lib/anim.glb --no-mesh --joint-prefix mixamorig:)
expect_exit(0 "wrote" export-builtin ${DIR}/lib/rotated.glb --rotate-frames 3)
expect_exit(0 "wrote" export-builtin ${DIR}/lib/longer.glb --rotate-frames 5 --bone-scale 1.3)
file(WRITE ${DIR}/lib/broken.fbx "this is not an FBX file\n")
file(WRITE ${DIR}/lib/empty.glb "")

# Exit codes on the character's own clips.
expect_exit(1 "touch: 121 frames, PENETRATES deeper than 1.00% of height: torso - arm_[lr]" check ${DIR}/builtin.glb --clip touch)
expect_exit(0 "walk: 31 frames, no penetration\n" check ${DIR}/builtin.glb --clip walk)
expect_exit(1 "2 clips.*1 penetrate deeper" check ${DIR}/builtin.glb --report ${DIR}/own.json)
expect_exit(0 "0 penetrate deeper" check ${DIR}/builtin.glb --clip touch --max-depth 0.05)

# A library with a broken and an empty file: both reported, the others checked, exit 2.
run_tool(check ${DIR}/builtin.glb --clips ${DIR}/lib/anim.glb ${DIR}/lib/broken.fbx ${DIR}/lib/rotated.glb
         ${DIR}/lib/empty.glb ${DIR}/lib/longer.glb --report ${DIR}/lib.json --csv ${DIR}/lib.csv --jobs 2)
string(REGEX MATCHALL "\n" newlines "${err}")
list(LENGTH newlines lines)
if(NOT rc EQUAL 2 OR NOT lines EQUAL 2 OR NOT err MATCHES "^skinspheres: [^\n]*broken.fbx: [^\n]*\nskinspheres: [^\n]*empty.glb: [^\n]*\n$"
   OR NOT out MATCHES "rotated/touch \\[[^\n]*rotated.glb\\]: 121 frames, PENETRATES"
   OR NOT out MATCHES "checked 6 clips [^\n]*: 3 penetrate deeper[^\n]*; 2 files could not be read or retargeted")
  message(SEND_ERROR "check with bad files: exit ${rc}, ${lines} lines on stderr:\n${err}\n${out}")
endif()
file(READ ${DIR}/lib.json report)
string(JSON n_clips LENGTH "${report}" clips)
string(JSON n_errors LENGTH "${report}" errors)
string(JSON bad_file GET "${report}" errors 0 file)
if(NOT n_clips EQUAL 6 OR NOT n_errors EQUAL 2 OR NOT bad_file MATCHES "broken.fbx$")
  message(SEND_ERROR "lib.json: ${n_clips} clips, ${n_errors} errors, first ${bad_file}")
endif()
file(STRINGS ${DIR}/lib.csv csv)
list(LENGTH csv csv_rows)
list(GET csv 0 csv_header)
if(csv_rows LESS 9 OR NOT csv_header MATCHES "^file,clip,frames,verdict,part_a,part_b,kind,")
  message(SEND_ERROR "lib.csv: ${csv_rows} rows, header ${csv_header}")
endif()

# A non-negative decimal (no exponent: 0 then) in millionths, as an integer CMake can compare.
function(micro value out)
  if(value MATCHES "[eE]" OR NOT value MATCHES "^([0-9]+)[.]?([0-9]*)")
    set(${out} 0 PARENT_SCOPE)
    return()
  endif()
  set(whole ${CMAKE_MATCH_1})
  string(SUBSTRING "${CMAKE_MATCH_2}000000" 0 6 fraction)
  math(EXPR m "${whole} * 1000000 + 1${fraction} - 1000000")
  set(${out} ${m} PARENT_SCOPE)
endfunction()

# The rigs with other rest frames (and longer bones) touch as the character's own clip does.
file(READ ${DIR}/own.json own)
string(JSON own_touch GET "${own}" clips 1)
string(JSON own_name GET "${own_touch}" name)
string(JSON own_pairs LENGTH "${own_touch}" part_pairs)
foreach(at 1 3 5)  # the touch clips of anim.glb, rotated.glb and longer.glb in the library's report
  string(JSON other GET "${report}" clips ${at})
  string(JSON other_name GET "${other}" name)
  string(JSON other_pairs LENGTH "${other}" part_pairs)
  if(NOT own_name STREQUAL "touch" OR NOT other_name MATCHES "/touch$" OR NOT own_pairs EQUAL other_pairs)
    message(SEND_ERROR "${other_name}: ${other_pairs} part pairs, ${own_name}: ${own_pairs}")
    continue()
  endif()
  math(EXPR last "${own_pairs} - 1")
  foreach(p RANGE ${last})
    foreach(field "parts" "frames" "penetrating_frames" "first_frame" "last_frame" "kind")
      string(JSON a GET "${own_touch}" part_pairs ${p} ${field})
      string(JSON b GET "${other}" part_pairs ${p} ${field})
      if(NOT a STREQUAL b)
        message(SEND_ERROR "${other_name} part pair ${p}: ${field} ${b}, the character's own touch: ${a}")
      endif()
    endforeach()
    string(JSON a GET "${own_touch}" part_pairs ${p} max_depth)
    string(JSON b GET "${other}" part_pairs ${p} max_depth)
    micro(${a} a_micro)
    micro(${b} b_micro)
    math(EXPR diff "${a_micro} - ${b_micro}")
    if(diff GREATER 200 OR diff LESS -200)  # 0.2 mm on a 1.8 m character
      message(SEND_ERROR "${other_name} part pair ${p}: depth ${b}, the character's own touch: ${a}")
    endif()
  endforeach()
  message(STATUS "${other_name}: the same ${other_pairs} part pairs, frames and depths as the character's own touch")
endforeach()

# --compare-source: rotated.glb holds the character itself (other rest frames, the same shape), so
# its clips penetrate there as here: nothing introduced by retargeting; anim.glb holds no character.
expect_exit(1 "compared with the characters[^\n]*\n  walk [^\n]*rotated.glb\\]: nothing introduced by retargeting; penetrating on its own character: none\n  touch [^\n]*rotated.glb\\]: nothing introduced by retargeting; penetrating on its own character: torso - arm_l, torso - arm_r"
            check ${DIR}/builtin.glb --clips ${DIR}/lib/rotated.glb ${DIR}/lib/anim.glb --compare-source --report ${DIR}/compare.json)
if(NOT out MATCHES "anim.glb: nothing to compare with \\([^\n]*no skinned mesh")
  message(SEND_ERROR "--compare-source on an animation-only file:\n${out}")
endif()
file(READ ${DIR}/compare.json compare)
string(JSON introduced LENGTH "${compare}" clips 1 compare_source introduced)
string(JSON there LENGTH "${compare}" clips 1 compare_source source_penetrating)
if(NOT introduced EQUAL 0 OR there LESS 2)
  message(SEND_ERROR "compare.json: touch introduces ${introduced} pairs, ${there} penetrate on the source")
endif()

# --html: one page per file, holding that file's clips.
expect_exit(1 "wrote [^\n]*pages/rotated.html\nwrote [^\n]*pages/anim.html"
            check ${DIR}/builtin.glb --clips ${DIR}/lib/rotated.glb ${DIR}/lib/anim.glb --html ${DIR}/pages)
file(READ ${DIR}/pages/rotated.html page)
string(REGEX MATCH "<script id=\"ss-data\" type=\"application/json\">([^<]*)</script>" unused "${page}")
string(JSON page_clips LENGTH "${CMAKE_MATCH_1}" character clips)
string(JSON page_clip GET "${CMAKE_MATCH_1}" clips 1 name)
if(NOT page_clips EQUAL 2 OR NOT page_clip STREQUAL "rotated/touch")
  message(SEND_ERROR "pages/rotated.html: ${page_clips} clips, the second ${page_clip}")
endif()

# One worker and two: the same report (less the time taken).
run_tool(check ${DIR}/builtin.glb --clips ${DIR}/lib/anim.glb ${DIR}/lib/rotated.glb --report ${DIR}/one.json --jobs 1)
run_tool(check ${DIR}/builtin.glb --clips ${DIR}/lib/anim.glb ${DIR}/lib/rotated.glb --report ${DIR}/two.json --jobs 2)
file(READ ${DIR}/one.json one)
file(READ ${DIR}/two.json two)
string(JSON one_clips GET "${one}" clips)
string(JSON two_clips GET "${two}" clips)
if(NOT one_clips STREQUAL two_clips)
  message(SEND_ERROR "--jobs 1 and --jobs 2 disagree")
endif()

# Bad options and hostile maps: one line, exit 2.
file(WRITE ${DIR}/cycle.json "{\"LeftArm\": \"RightArm\", \"RightArm\": \"LeftArm\"}")
file(WRITE ${DIR}/unknown.json "{\"Hips\": \"NoSuchJoint\"}")
file(WRITE ${DIR}/twice.json "{\"Hips\": \"Hips\", \"Spine\": \"Hips\"}")
file(WRITE ${DIR}/key_twice.json "{\"Hips\": \"Hips\", \"Hips\": \"Spine\"}")
file(WRITE ${DIR}/empty.json "")
set(lib ${DIR}/lib/rotated.glb)
expect_bad_input("[^\n]*cycle.json: \"LeftArm\" -> \"RightArm\" -> \"LeftArm\" is a cycle" play ${DIR}/builtin.glb --clips ${lib} --joint-map ${DIR}/cycle.json)
expect_bad_input("[^\n]*unknown.json: \"NoSuchJoint\" names no joint of" check ${DIR}/builtin.glb --clips ${lib} --joint-map ${DIR}/unknown.json)
expect_bad_input("[^\n]*twice.json: the target joint \"Hips\" is named twice" check ${DIR}/builtin.glb --clips ${lib} --joint-map ${DIR}/twice.json)
expect_bad_input("[^\n]*key_twice.json: \"Hips\" is mapped twice" check ${DIR}/builtin.glb --clips ${lib} --joint-map ${DIR}/key_twice.json)
expect_bad_input("[^\n]*empty.json: malformed JSON" play ${DIR}/builtin.glb --clips ${lib} --joint-map ${DIR}/empty.json)
expect_bad_input("[^\n]*no_map.json: file not found" play ${DIR}/builtin.glb --clips ${lib} --joint-map ${DIR}/no_map.json)
expect_bad_input("[^\n]*lib: is a directory" play ${DIR}/builtin.glb --clips ${lib} --joint-map ${DIR}/lib)
expect_bad_input("--source-rest: [^\n]*anim.glb: no skinned mesh" play ${DIR}/builtin.glb --clips ${lib} --source-rest ${DIR}/lib/anim.glb)
expect_bad_input("--source-rest: /dev/zero: " play ${DIR}/builtin.glb --clips ${lib} --source-rest /dev/zero)
expect_bad_input("--retarget must be auto, copy or world" check ${DIR}/builtin.glb --clips ${lib} --retarget mirror)
expect_bad_input("--max-depth must be a share" check ${DIR}/builtin.glb --max-depth 2)
expect_bad_input("[^\n]*broken.fbx: " check ${DIR}/builtin.glb --clips ${DIR}/lib/broken.fbx)
expect_bad_input("[^\n]*lib: is a directory" check ${DIR}/builtin.glb --clips ${DIR}/lib)
# An animation-only file of another rig has no rest pose of its own: the line names the option.
expect_exit(0 "wrote" export-builtin ${DIR}/rotated_anim.glb --rotate-frames 3 --no-mesh)
expect_bad_input("[^\n]*rotated_anim.glb: made for another rig [^\n]*--source-rest RIG" play ${DIR}/builtin.glb --clips ${DIR}/rotated_anim.glb)
expect_exit(0 "rest pose: the bind pose of [^\n]*rotated.glb.*clip \"rotated_anim/touch\": 121 frames"
            play ${DIR}/builtin.glb --clips ${DIR}/rotated_anim.glb --source-rest ${DIR}/lib/rotated.glb --clip rotated_anim/touch)
# --source-rest FRAME: a frame past a clip's end is refused (the sampler would hold the last key, a
# pose nobody chose); the last frame itself is taken. A frame that is not a rest pose (frame 30 of
# the touch clip: the hands on the chest) gets a warning naming the options; frame 0 (at rest) none.
expect_bad_input("[^\n]*rotated_anim.glb: frame 31 of each clip \\(--source-rest\\) lies past the end of clip \"walk\" \\(1 s long, its last frame is 30 at 30 fps\\)"
                 play ${DIR}/builtin.glb --clips ${DIR}/rotated_anim.glb --source-rest 31)
expect_bad_input("[^\n]*rotated_anim.glb: frame 99999 of each clip \\(--source-rest\\) lies past the end of clip"
                 check ${DIR}/builtin.glb --clips ${DIR}/rotated_anim.glb --source-rest 99999)
expect_exit(0 "warning: the clip's rest pose and the character's differ by 1[0-9][0-9]\\.[0-9]° on arm_[lr] [^\n]*that frame is likely not a rest pose; give --source-rest RIG"
            play ${DIR}/builtin.glb --clips ${DIR}/rotated_anim.glb --source-rest 30 --clip rotated_anim/touch --frames 2)
run_tool(play ${DIR}/builtin.glb --clips ${DIR}/rotated_anim.glb --source-rest 0 --clip rotated_anim/touch --frames 2)
if(NOT rc EQUAL 0 OR out MATCHES "warning" OR NOT out MATCHES "rest poses differ by up to 0\\.0°")
  message(SEND_ERROR "--source-rest 0 (a rest pose): exit ${rc}, a warning or a difference:\n${out}\n${err}")
endif()
expect_exit(0 "source rest pose: frame 30 of each clip" play ${DIR}/builtin.glb --clips ${DIR}/rotated_anim.glb --source-rest 30 --clip rotated_anim/walk --frames 2)
