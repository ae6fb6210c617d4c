// Mesh the box-minus-cylinder and attach post-processing views built on the mesh.
Include "boxcyl.geo";
Mesh 3;
// View 0: nodal scalar "pressure", two time steps (values differ by 1000).
Plugin(NewView).NumComp = 1;
Plugin(NewView).Run;
Plugin(ModifyComponents).View = 0;
Plugin(ModifyComponents).Expression0 = "x + 10*y + 100*z";
Plugin(ModifyComponents).Run;
Plugin(NewView).Run;
Plugin(ModifyComponents).View = 1;
Plugin(ModifyComponents).Expression0 = "1000 + x + 10*y + 100*z";
Plugin(ModifyComponents).Run;
View[0].Name = "pressure";
View[1].Name = "pressure";
Combine TimeStepsByViewName;
// View 1: nodal vector "velocity" = (x, y, z).
Plugin(NewView).NumComp = 3;
Plugin(NewView).Run;
Plugin(ModifyComponents).View = 1;
Plugin(ModifyComponents).Expression0 = "x";
Plugin(ModifyComponents).Expression1 = "y";
Plugin(ModifyComponents).Expression2 = "z";
Plugin(ModifyComponents).Run;
View[1].Name = "velocity";
// View 2: element data from the mesh quality plugin (ICN per tetrahedron).
Plugin(AnalyseMeshQuality).ICNMeasure = 1;
Plugin(AnalyseMeshQuality).JacobianDeterminant = 0;
Plugin(AnalyseMeshQuality).CreateView = 1;
Plugin(AnalyseMeshQuality).Run;
Printf("views: %g", PostProcessing.NbViews);
