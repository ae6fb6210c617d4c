#!/bin/sh
# Regenerates the Gmsh test meshes with Debian's gmsh 4.8.4 (apt-get install gmsh).
# Run from this directory: sh generate.sh
set -e
trap "rm -f *.geo_unrolled" EXIT
# boxcyl_{22,41}_{ascii,bin}.msh: tetrahedra + NodeData "pressure_Combine" (2 time steps),
# NodeData "velocity" (3 components), ElementData "ICN 3D" (per tetrahedron). Gmsh writes
# each view to its own file; the data-only files are appended after dropping their $MeshFormat.
for ver in 2.2 4.1; do for bin in 0 1; do
  tag=$(echo $ver | tr -d .)_$( [ $bin = 1 ] && echo bin || echo ascii)
  cat > save_$tag.geo <<EOG
Include "boxcyl_view.geo";
Mesh.MshFileVersion = $ver;
Mesh.Binary = $bin;
Save View[0] "part_${tag}_0.msh";
PostProcessing.SaveMesh = 0;
Save View[1] "part_${tag}_1.msh";
Save View[2] "part_${tag}_2.msh";
EOG
  gmsh save_$tag.geo -0 > /dev/null
  { cat part_${tag}_0.msh; for p in 1 2; do
      off=$(grep -boa '^\$EndMeshFormat' part_${tag}_$p.msh | head -1 | cut -d: -f1)
      tail -c +$((off + 16)) part_${tag}_$p.msh; done; } > boxcyl_$tag.msh
  rm -f save_$tag.geo part_${tag}_*.msh
done; done
gmsh -3 hexbox.geo -format msh22 -o hexbox_22_ascii.msh > /dev/null
gmsh -3 hexbox.geo -format msh41 -bin -o hexbox_41_bin.msh > /dev/null
gmsh -3 hexbox.geo -format msh41 -string "Mesh.SaveParametric = 1;" -o hexbox_param_41_ascii.msh > /dev/null
gmsh -3 -order 3 -setnumber nx 2 -setnumber ny 3 -setnumber nz 2 hexbox.geo -format msh41 -o hexbox_o3_41_ascii.msh > /dev/null
gmsh -3 mixed.geo -format msh22 -o mixed_22_ascii.msh > /dev/null
gmsh -3 mixed.geo -format msh41 -o mixed_41_ascii.msh > /dev/null
gmsh -3 -order 2 mixed.geo -format msh41 -o mixed_o2_41_ascii.msh > /dev/null
gmsh -3 -order 2 -string "Mesh.SecondOrderIncomplete = 1;" mixed.geo -format msh22 -bin -o mixed_o2i_22_bin.msh > /dev/null
gmsh -3 -order 3 -setnumber lc 0.5 mixed.geo -format msh41 -bin -o mixed_o3_41_bin.msh > /dev/null
gmsh -3 -order 2 -setnumber h 0.35 boxcyl.geo -format msh41 -bin -o boxcyl_o2_41_bin.msh > /dev/null
