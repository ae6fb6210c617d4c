"""Writes boxcyl_o3_41_bin.msh: boxcyl.geo meshed at h = 0.5 with complete
third-order tetrahedra (20 nodes), Gmsh 4.1 binary. Run with Gmsh's Python
package (gmsh 4.15.2 from PyPI) in this directory:

    python boxcyl_o3.py boxcyl_o3_41_bin.msh
"""
import gmsh, sys
gmsh.initialize(); gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1); gmsh.option.setNumber("Mesh.Binary", 1)
gmsh.onelab.set('[{"type":"number","name":"h","values":[0.5]}]')
gmsh.open("boxcyl.geo")
gmsh.option.setNumber("Mesh.CharacteristicLengthMax", 0.5)
gmsh.model.mesh.generate(3)
gmsh.model.mesh.setOrder(3)
gmsh.write(sys.argv[1])
