# The tool's clip-file and page options, and their error paths (exit 2, one line on stderr naming
# the file and the problem). Inputs come from export-builtin (no shared character needed).
#   cmake -DTOOL=... -DDIR=... -P clip_files_and_pages.cmake
file(REMOVE_RECURSE ${DIR})
file(MAKE_DIRECTORY ${DIR})
set(failures 0)

include(${CMAKE_CURRENT_LIST_DIR}/tool_checks.cmake)

expect_ok("wrote" export-builtin ${DIR}/builtin.glb)
expect_ok("wrote" export-builtin ${DIR}/builtin_noclips.glb --no-clips)
expect_ok("wrote .*0 vertices, 0 triangles, 26 joints, 2 clips" export-builtin ${DIR}/anim.glb --no-mesh --joint-prefix mixamorig:)
expect_ok("wrote" export-builtin ${DIR}/anim.fbx --no-mesh --joint-prefix mixamorig:)
expect_ok("wrote" export-builtin ${DIR}/other_rig.glb --no-mesh --joint-prefix Rig_)

# fit on an animation-only file says what it is.
foreach(f anim.glb anim.fbx)
  expect_bad_input("[^\n]*${f}: no skinned mesh \\([0-9]+ nodes, 2 animations, 0 meshes\\): an animation-only file; use it with play --clips"
                   fit ${DIR}/${f})
endforeach()

# play --clips: clips from the GLB and the FBX (names taken: renamed "<stem>/<name>").
expect_ok("clips from [^\n]*anim.fbx: anim/walk, anim/touch \\([0-9]+ joints matched[^)]*copied: the same rig\\).*clip \"anim/touch\": 121 frames.*torso - arm_l"
          play ${DIR}/builtin.glb --clips ${DIR}/anim.fbx --clip anim/touch)
expect_ok("clips from [^\n]*anim.glb: walk, touch.*clip \"touch\": 121 frames"
          play ${DIR}/builtin_noclips.glb --clips ${DIR}/anim.glb --clip touch --html ${DIR}/clips.html)
expect_bad_input("[^\n]*other_rig.glb: cannot drive [^\n]*builtin.glb: no joint of this file matches its hips \\(Hips\\), spine \\(Spine\\), left upper arm \\(LeftArm\\)[^\n]*--joint-map"
                 play ${DIR}/builtin.glb --clips ${DIR}/other_rig.glb)
expect_bad_input("[^\n]*missing.fbx: file not found" play ${DIR}/builtin.glb --clips ${DIR}/missing.fbx)
expect_bad_input("[^\n]*builtin_noclips.glb: has no animation clips" play ${DIR}/builtin_noclips.glb --html ${DIR}/x.html)

# --html: pages are written; an unwritable path is one line naming it.
expect_ok("wrote [^\n]*fit.html" fit ${DIR}/builtin.glb --html ${DIR}/fit.html)
expect_ok("wrote [^\n]*play.html" play ${DIR}/builtin.glb --clip all --frames 5 --html ${DIR}/play.html)
expect_bad_input("[^\n]*no_such_dir/p.html: cannot open for writing" play ${DIR}/builtin.glb --frames 2 --html ${DIR}/no_such_dir/p.html)
expect_bad_input("[^\n]*no_such_dir/f.html: cannot open for writing" fit ${DIR}/builtin.glb --html ${DIR}/no_such_dir/f.html)
expect_bad_input("[^\n]*no_such_dir/d.html: cannot open for writing" demo --html ${DIR}/no_such_dir/d.html)
expect_bad_input("[^\n]*x.obj: export-builtin writes .glb or .fbx" export-builtin ${DIR}/x.obj)
expect_bad_input("--armature-scale must be a positive number" export-builtin ${DIR}/y.glb --armature-scale 0)
expect_ok("page: [^\n]*demo.html" demo --html ${DIR}/demo.html)

# --export-glb: the spheres move in the played clip's own animation.
expect_ok("animated spheres, in clip \"touch\"" play ${DIR}/builtin.glb --clip touch --frames 8 --export-glb ${DIR}/v.glb)
