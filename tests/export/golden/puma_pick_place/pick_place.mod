MODULE pick_place
  ! pick_place: device 'puma', from workcells/puma560/programs/pick_place.yaml
  ! written by 'rworld export program': targets resolved with the cell's current pose files
  ! outputs: gripper do_1 (1 = closed), tool changer do_2 (1 = locked); searches stop on di_1
  ! tool data in the flange frame: the last link's (no controller flange given)
  ! targets in the base frame: 'puma' (no controller base given)
  ! axis values: the cell's joint values
  PERS wobjdata wobj_base := [FALSE,TRUE,"",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  ! t_puma_tool is puma.tool
  ! no tool mass in the cell: RAPID's smallest load (0.001 kg) stands in
  PERS tooldata t_puma_tool := [TRUE,[[0,0,0],[1,0,0,0]],[0.001,[0,0,0.001],[1,0,0,0],0,0,0]];
  ! t_puma_probe is puma.probe
  ! no tool mass in the cell: RAPID's smallest load (0.001 kg) stands in
  PERS tooldata t_puma_probe := [TRUE,[[0,0,100],[1,0,0,0]],[0.001,[0,0,0.001],[1,0,0,0],0,0,0]];
  ! p3: workcells/puma560/programs/pick_place.yaml:9 move to ready
  CONST jointtarget j3 := [[0,45,-135,0,-45,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p3 := [[737.128708,-150.05,956.858708],[0.382683432365,0,0.923879532511,0],[0,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s3 := [1038.304,500,5000,1000];
  ! p5: workcells/puma560/programs/pick_place.yaml:10 move to workpiece.grasp
  CONST jointtarget j5 := [[32.159231613,42.639713528,-176.595133608,-0.000000002,-46.044579916,-177.840768385],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p5 := [[600,200,550],[0.000000000005,0.965925826291,0.258819045095,0.000000000038],[0,-1,-2,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s5 := [1088.056,500,5000,1000];
  ! p6: workcells/puma560/programs/pick_place.yaml:11 move to workpiece.grasp (linear)
  CONST jointtarget j6 := [[32.159231609,32.354593311,-174.389015177,0,-37.965578134,-177.840768391],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p6 := [[599.999998,199.999999,450],[0,0.965925826289,0.258819045103,0],[0,0,-2,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s6 := [125,500,5000,1000];
  PERS loaddata load1 := [1.2,[0.000002,0,125],[1,0,0,0],0.00125,0.00225,0.0035];
  ! p9: workcells/puma560/programs/pick_place.yaml:13 move to table.drop
  CONST jointtarget j9 := [[-13.639703236,38.906299534,-168.890973832,0,-50.015325701,-193.639703236],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p9 := [[600,-300,550],[0,1,0,0],[-1,0,-3,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s9 := [1278.562,500,5000,1000];
  ! p10: workcells/puma560/programs/pick_place.yaml:14 move to table.drop (linear)
  CONST jointtarget j10 := [[-13.639703239,29.144437512,-166.655067913,0,-42.489369599,-193.639703239],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p10 := [[599.999998,-300,450],[0,1,0,0],[-1,0,-3,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s10 := [125,500,5000,1000];
  ! p13: workcells/puma560/programs/pick_place.yaml:16 move to table.drop (linear)
  CONST jointtarget j13 := [[-13.639703239,38.906299702,-168.890974185,0,-50.015325517,-193.639703239],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p13 := [[599.999998,-300,550],[0,1,0,0],[-1,0,-3,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s13 := [249.999,500,5000,1000];
  ! p15: workcells/puma560/programs/pick_place.yaml:17 move to home
  CONST jointtarget j15 := [[0,45,-180,0,45,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p15 := [[596.303149,-150.05,657.475732],[0.707106781187,0,0.707106781187,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s15 := [262.934,500,5000,1000];
  PROC main()
    ! load on the flange: none
    GripLoad load0;
    ! workcells/puma560/programs/pick_place.yaml:9: move to ready
    MoveAbsJ j3, s3, fine, t_puma_tool\WObj:=wobj_base;
    ! workcells/puma560/programs/pick_place.yaml:10: move to workpiece.grasp
    MoveAbsJ j5, s5, fine, t_puma_probe\WObj:=wobj_base;
    ! workcells/puma560/programs/pick_place.yaml:11: move to workpiece.grasp (linear)
    MoveL p6, s6, fine, t_puma_probe\WObj:=wobj_base;
    ! workcells/puma560/programs/pick_place.yaml:12: grasp workpiece
    SetDO do_1, 1;
    ! load on the flange: workpiece 1.2 kg
    GripLoad load1;
    ! workcells/puma560/programs/pick_place.yaml:13: move to table.drop
    MoveAbsJ j9, s9, fine, t_puma_probe\WObj:=wobj_base;
    ! workcells/puma560/programs/pick_place.yaml:14: move to table.drop (linear)
    MoveL p10, s10, fine, t_puma_probe\WObj:=wobj_base;
    ! workcells/puma560/programs/pick_place.yaml:15: place workpiece on table.top_center
    SetDO do_1, 0;
    ! load on the flange: none
    GripLoad load0;
    ! workcells/puma560/programs/pick_place.yaml:16: move to table.drop (linear)
    MoveL p13, s13, fine, t_puma_probe\WObj:=wobj_base;
    ! workcells/puma560/programs/pick_place.yaml:17: move to home
    MoveAbsJ j15, s15, fine, t_puma_tool\WObj:=wobj_base;
  ENDPROC
ENDMODULE
