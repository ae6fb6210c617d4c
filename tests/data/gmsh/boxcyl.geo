// Box minus a cylinder, meshed with tetrahedra. Physical volume "solid" (7) and
// physical surface "skin" (8). Mesh size h (override with -setnumber h ...).
SetFactory("OpenCASCADE");
DefineConstant[ h = 0.2 ];
Box(1) = {0, 0, 0, 2, 1, 1};
Cylinder(2) = {1, 0.5, -0.1, 0, 0, 1.2, 0.25};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
Physical Volume("solid", 7) = {3};
Physical Surface("skin", 8) = Surface{:};
Mesh.CharacteristicLengthMax = h;
