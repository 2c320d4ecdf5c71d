MODULE robot
  ! robot: device 'robot', from workcells/paper_fig9/programs/robot.yaml
  ! written by 'rworld export program': targets resolved with the cell's current pose files
  ! outputs: gripper do_1 (1 = closed), tool changer do_2 (1 = locked); searches stop on di_1
  ! tool data in the flange frame: the last link's (no controller flange given)
  ! targets in the base frame: 'robot' (no controller base given)
  ! axis values: the cell's joint values
  PERS wobjdata wobj_base := [FALSE,TRUE,"",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  ! t_hand_a_tcp is hand_a.tcp
  PERS tooldata t_hand_a_tcp := [TRUE,[[0,130,113.923048],[0.965925826289,-0.258819045103,0,0]],[0.9,[0,-45.833333,72.065154],[0.56462887582,0.425669158608,0.56462887582,0.425669158608],0.000777,0.009355,0.010072]];
  ! t_hand_b_tcp is hand_b.tcp
  PERS tooldata t_hand_b_tcp := [TRUE,[[0,-130,113.923048],[0.965925826289,0.258819045103,0,0]],[0.9,[0,-43.333333,76.395281],[0.549148869679,0.445461018418,0.549148869679,0.445461018418],0.000871,0.009704,0.010515]];
  ! t_robot_tool_plate is robot.tool_plate
  PERS tooldata t_robot_tool_plate := [TRUE,[[0,0,10],[1,0,0,0]],[0.6,[0,0.000228,57.631002],[0.000001432444,-0.707106781185,-0.707106781185,-0.000001432444],0,0.005704,0.005704]];
  PERS loaddata load1 := [1.12,[0,-58.836629,113.086419],[0.504401548371,0.495559358706,0.504401548371,0.495559358706],0.000665,0.014747,0.014932];
  ! p4: workcells/paper_fig9/programs/robot.yaml:8 move to table.slot_part
  CONST jointtarget j4 := [[-97.367772014,-90.249675836,72.673648908,-102.21870697,-86.323736367,-6.389462907],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p4 := [[-50,449.999998,444.999997],[0.000000000454,-1,-0.000000000036,0.000000000023],[-2,-2,-1,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s4 := [1389.597,500,5000,1000];
  ! p5: workcells/paper_fig9/programs/robot.yaml:9 move to table.slot_part (linear)
  CONST jointtarget j5 := [[-97.367771927,-92.719117659,92.876490925,-119.952107118,-86.323736421,-6.389462832],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p5 := [[-50,449.999997,325],[0,1,0,0],[-2,-2,-1,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s5 := [125,500,5000,1000];
  PERS loaddata load2 := [0.8,[0,-130,113.923048],[0.612372435696,-0.353553390593,-0.353553390593,-0.612372435696],0.0004,0.0006,0.0006];
  ! p10: workcells/paper_fig9/programs/robot.yaml:13 move to table.slot_part (linear)
  CONST jointtarget j10 := [[-97.367771927,-90.249675887,72.673648688,-102.218706654,-86.323736421,-6.389462832],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p10 := [[-50,449.999997,444.999999],[0,-1,0,0],[-2,-2,-1,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s10 := [250.001,500,5000,1000];
  ! p12: workcells/paper_fig9/programs/robot.yaml:14 move to table.slot_assembly
  CONST jointtarget j12 := [[-122.711101418,-82.354221316,43.58679965,-25.322744293,-105.676268286,-29.083486302],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p12 := [[150,450,480],[0.000000000001,-1,0,0],[-2,-1,-1,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s12 := [731.856,500,5000,1000];
  ! p13: workcells/paper_fig9/programs/robot.yaml:15 move to table.slot_assembly (linear)
  CONST jointtarget j13 := [[-122.711101418,-92.544351801,78.941716492,-50.487530651,-105.676268286,-29.083486302],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p13 := [[149.999998,449.999997,329.999999],[0,1,0,0],[-2,-1,-1,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s13 := [125.001,500,5000,1000];
  ! p18: workcells/paper_fig9/programs/robot.yaml:19 move to table.slot_assembly (linear)
  CONST jointtarget j18 := [[-122.711101418,-82.354222855,43.586802625,-25.322745729,-105.676268286,-29.083486302],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p18 := [[149.999997,449.999996,479.999994],[0,-1,0,0],[-2,-1,-1,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s18 := [250.003,500,5000,1000];
  ! p20: workcells/paper_fig9/programs/robot.yaml:20 move to home
  CONST jointtarget j20 := [[0,-90,90,-90,-90,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p20 := [[-486.9,-109.15,422.159],[0,0.707106781187,0.707106781187,0],[0,-1,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s20 := [1591.443,500,5000,1000];
  ! p21: workcells/paper_fig9/programs/robot.yaml:21 move to tool_rack.hand_a_slot
  CONST jointtarget j21 := [[-78.553400408,-155.057697984,25.775549417,39.282148567,-90,11.446599592],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p21 := [[0,-550,480],[0,-1,0,0],[-1,0,0,5],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s21 := [1572.207,500,5000,1000];
  ! p22: workcells/paper_fig9/programs/robot.yaml:22 move to tool_rack.hand_a_slot (linear)
  CONST jointtarget j22 := [[-78.553400408,-172.860645222,50.143912234,32.716732988,-90,11.446599592],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p22 := [[-0.000001,-549.999997,380],[0,-1,0,0],[-1,0,0,5],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s22 := [116.31,500,5000,1000];
  ! p25: workcells/paper_fig9/programs/robot.yaml:24 move to tool_rack.hand_a_slot (linear)
  CONST jointtarget j25 := [[-78.553400408,-155.05770049,25.775554797,39.282145693,-90,11.446599592],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p25 := [[-0.000002,-549.999992,479.999995],[0,-1,0,0],[-1,0,0,5],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s25 := [232.488,500,5000,1000];
  ! p26: workcells/paper_fig9/programs/robot.yaml:25 move to home
  CONST jointtarget j26 := [[0,-90,90,-90,-90,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p26 := [[-486.9,-109.15,422.159],[0,0.707106781187,0.707106781187,0],[0,-1,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST speeddata s26 := [1571.6,500,5000,1000];
  PROC main()
    ! workcells/paper_fig9/programs/robot.yaml:7: sync arrived (at t = 0.000 s in the simulation)
    ! load on the flange: hand_a, hand_b, shaft, cap 0.9 kg; part, housing 1.12 kg
    GripLoad load1;
    ! workcells/paper_fig9/programs/robot.yaml:8: move to table.slot_part
    MoveAbsJ j4, s4, fine, t_hand_a_tcp\WObj:=wobj_base;
    ! workcells/paper_fig9/programs/robot.yaml:9: move to table.slot_part (linear)
    MoveL p5, s5, fine, t_hand_a_tcp\WObj:=wobj_base;
    ! workcells/paper_fig9/programs/robot.yaml:10: place part on table
    SetDO do_1, 0;
    ! workcells/paper_fig9/programs/robot.yaml:11: sync part_placed (at t = 4.626 s in the simulation)
    ! workcells/paper_fig9/programs/robot.yaml:12: sync hand_a_open (at t = 4.626 s in the simulation)
    ! load on the flange: hand_a, hand_b, shaft, cap 0.9 kg; housing 0.8 kg
    GripLoad load2;
    ! workcells/paper_fig9/programs/robot.yaml:13: move to table.slot_part (linear)
    MoveL p10, s10, fine, t_hand_a_tcp\WObj:=wobj_base;
    ! workcells/paper_fig9/programs/robot.yaml:14: move to table.slot_assembly
    MoveAbsJ j12, s12, fine, t_hand_b_tcp\WObj:=wobj_base;
    ! workcells/paper_fig9/programs/robot.yaml:15: move to table.slot_assembly (linear)
    MoveL p13, s13, fine, t_hand_b_tcp\WObj:=wobj_base;
    ! workcells/paper_fig9/programs/robot.yaml:16: place housing on table
    SetDO do_1, 0;
    ! workcells/paper_fig9/programs/robot.yaml:17: sync housing_placed (at t = 7.952 s in the simulation)
    ! workcells/paper_fig9/programs/robot.yaml:18: sync hand_b_open (at t = 7.952 s in the simulation)
    ! load on the flange: hand_a, hand_b 0.6 kg
    GripLoad load0;
    ! workcells/paper_fig9/programs/robot.yaml:19: move to table.slot_assembly (linear)
    MoveL p18, s18, fine, t_hand_b_tcp\WObj:=wobj_base;
    ! workcells/paper_fig9/programs/robot.yaml:20: move to home
    MoveAbsJ j20, s20, fine, t_robot_tool_plate\WObj:=wobj_base;
    ! workcells/paper_fig9/programs/robot.yaml:21: move to tool_rack.hand_a_slot
    MoveAbsJ j21, s21, fine, t_robot_tool_plate\WObj:=wobj_base;
    ! workcells/paper_fig9/programs/robot.yaml:22: move to tool_rack.hand_a_slot (linear)
    MoveL p22, s22, fine, t_robot_tool_plate\WObj:=wobj_base;
    ! workcells/paper_fig9/programs/robot.yaml:23: detach_tool hand_a
    SetDO do_2, 0;
    ! load on the flange: hand_b 0.3 kg
    GripLoad load0;
    ! workcells/paper_fig9/programs/robot.yaml:24: move to tool_rack.hand_a_slot (linear)
    MoveL p25, s25, fine, t_robot_tool_plate\WObj:=wobj_base;
    ! workcells/paper_fig9/programs/robot.yaml:25: move to home
    MoveAbsJ j26, s26, fine, t_robot_tool_plate\WObj:=wobj_base;
  ENDPROC
ENDMODULE
