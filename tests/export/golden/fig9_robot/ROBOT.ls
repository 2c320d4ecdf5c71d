/PROG  ROBOT
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "rworld";
PROG_SIZE	= 0;
CREATE		= DATE 00-01-01  TIME 00:00:00;
MODIFIED	= DATE 00-01-01  TIME 00:00:00;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 179;
MEMORY_SIZE	= 0;
PROTECT		= READ_WRITE;
TCD:  STACK_SIZE	= 0,
      TASK_PRIORITY	= 50,
      TIME_SLICE	= 0,
      BUSY_LAMP_OFF	= 0,
      ABORT_REQUEST	= 0,
      PAUSE_REQUEST	= 0;
DEFAULT_GROUP	= 1,*,*,*,*;
CONTROL_CODE	= 00000000 00000000;
/MN
   1:  !robot: device 'robot', from work ;
   2:  !cells/paper_fig9/programs/robot. ;
   3:  !yaml ;
   4:  !written by 'rworld export ;
   5:  !program': targets resolved with ;
   6:  !the cell's current pose files ;
   7:  !outputs: gripper DO[1] (ON = ;
   8:  !closed), tool changer DO[2] (ON ;
   9:  != locked), searches skip on ;
  10:  !DI[1] ;
  11:  !'ROBOT' is program 'robot' ;
  12:  !tool data in the flange frame: ;
  13:  !the last link's (no controller ;
  14:  !flange given) ;
  15:  !targets in the base frame: ;
  16:  !'robot' (no controller base ;
  17:  !given) ;
  18:  !axis values: the cell's joint ;
  19:  !values ;
  20:  !CONFIG: F when J5 > 0, U elbow ;
  21:  !up, T wrist centre in front of ;
  22:  !J1, then the turns of J4, J5, J6 ;
  23:  !PR[90] carries tool and user ;
  24:  !frame values, PR[91] a probe's ;
  25:  !stop ;
  26:  !UFRAME 0: the world frame (the ;
  27:  !robot's base) ;
  28:  UFRAME_NUM=0 ;
  29:  !workcells/paper_fig9/programs/ro ;
  30:  !bot.yaml:7: sync arrived (at t = ;
  31:  !0.000 s in the simulation) ;
  32:  !load on the flange: hand_a, ;
  33:  !hand_b, shaft, cap 0.9 kg\x3b ;
  34:  !part, housing 1.12 kg ;
  35:  !products of inertia dropped: ;
  36:  !FANUC takes IX, IY, IZ only ;
  37:  !kg, cm, kgf cm s^2, flange axes ;
  38:  $PLST_GRP1[1].$PAYLOAD=2.020000 ;
  39:  $PLST_GRP1[1].$PAYLOAD_X=0.000000 ;
  40:  $PLST_GRP1[1].$PAYLOAD_Y=-5.304308 ;
  41:  $PLST_GRP1[1].$PAYLOAD_Z=9.480962 ;
  42:  $PLST_GRP1[1].$PAYLOAD_IX=0.264391 ;
  43:  $PLST_GRP1[1].$PAYLOAD_IY=0.029935 ;
  44:  $PLST_GRP1[1].$PAYLOAD_IZ=0.239962 ;
  45:  PAYLOAD[1] ;
  46:  !UTOOL[1] is hand_a.tcp ;
  47:  PR[90]=LPOS-LPOS ;
  48:  PR[90,1]=0.000000 ;
  49:  PR[90,2]=130.000000 ;
  50:  PR[90,3]=113.923048 ;
  51:  PR[90,4]=-30.000000 ;
  52:  PR[90,5]=0.000000 ;
  53:  PR[90,6]=0.000000 ;
  54:  UTOOL[1]=PR[90] ;
  55:  UTOOL_NUM=1 ;
  56:  !workcells/paper_fig9/programs/ro ;
  57:  !bot.yaml:8: move to ;
  58:  !table.slot_part ;
  59:J P[1] 100% FINE ;
  60:  !workcells/paper_fig9/programs/ro ;
  61:  !bot.yaml:9: move to ;
  62:  !table.slot_part (linear) ;
  63:L P[2] 125mm/sec FINE ;
  64:  !workcells/paper_fig9/programs/ro ;
  65:  !bot.yaml:10: place part on table ;
  66:  DO[1]=OFF ;
  67:  !workcells/paper_fig9/programs/ro ;
  68:  !bot.yaml:11: sync part_placed ;
  69:  !(at t = 4.626 s in the ;
  70:  !simulation) ;
  71:  !workcells/paper_fig9/programs/ro ;
  72:  !bot.yaml:12: sync hand_a_open ;
  73:  !(at t = 4.626 s in the ;
  74:  !simulation) ;
  75:  !load on the flange: hand_a, ;
  76:  !hand_b, shaft, cap 0.9 kg\x3b ;
  77:  !housing 0.8 kg ;
  78:  !products of inertia dropped: ;
  79:  !FANUC takes IX, IY, IZ only ;
  80:  !kg, cm, kgf cm s^2, flange axes ;
  81:  $PLST_GRP1[1].$PAYLOAD=1.700000 ;
  82:  $PLST_GRP1[1].$PAYLOAD_X=0.000000 ;
  83:  $PLST_GRP1[1].$PAYLOAD_Y=-8.411765 ;
  84:  $PLST_GRP1[1].$PAYLOAD_Z=9.405541 ;
  85:  $PLST_GRP1[1].$PAYLOAD_IX=0.151858 ;
  86:  $PLST_GRP1[1].$PAYLOAD_IY=0.024402 ;
  87:  $PLST_GRP1[1].$PAYLOAD_IZ=0.132147 ;
  88:  PAYLOAD[1] ;
  89:  !workcells/paper_fig9/programs/ro ;
  90:  !bot.yaml:13: move to ;
  91:  !table.slot_part (linear) ;
  92:L P[3] 250mm/sec FINE ;
  93:  !UTOOL[2] is hand_b.tcp ;
  94:  PR[90]=LPOS-LPOS ;
  95:  PR[90,1]=0.000000 ;
  96:  PR[90,2]=-130.000000 ;
  97:  PR[90,3]=113.923048 ;
  98:  PR[90,4]=30.000000 ;
  99:  PR[90,5]=0.000000 ;
 100:  PR[90,6]=0.000000 ;
 101:  UTOOL[2]=PR[90] ;
 102:  UTOOL_NUM=2 ;
 103:  !workcells/paper_fig9/programs/ro ;
 104:  !bot.yaml:14: move to ;
 105:  !table.slot_assembly ;
 106:J P[4] 100% FINE ;
 107:  !workcells/paper_fig9/programs/ro ;
 108:  !bot.yaml:15: move to ;
 109:  !table.slot_assembly (linear) ;
 110:L P[5] 125mm/sec FINE ;
 111:  !workcells/paper_fig9/programs/ro ;
 112:  !bot.yaml:16: place housing on ;
 113:  !table ;
 114:  DO[1]=OFF ;
 115:  !workcells/paper_fig9/programs/ro ;
 116:  !bot.yaml:17: sync housing_placed ;
 117:  !(at t = 7.952 s in the ;
 118:  !simulation) ;
 119:  !workcells/paper_fig9/programs/ro ;
 120:  !bot.yaml:18: sync hand_b_open ;
 121:  !(at t = 7.952 s in the ;
 122:  !simulation) ;
 123:  !load on the flange: hand_a, ;
 124:  !hand_b 0.6 kg ;
 125:  !kg, cm, kgf cm s^2, flange axes ;
 126:  $PLST_GRP1[1].$PAYLOAD=0.600000 ;
 127:  $PLST_GRP1[1].$PAYLOAD_X=0.000000 ;
 128:  $PLST_GRP1[1].$PAYLOAD_Y=0.000023 ;
 129:  $PLST_GRP1[1].$PAYLOAD_Z=5.763100 ;
 130:  $PLST_GRP1[1].$PAYLOAD_IX=0.058162 ;
 131:  $PLST_GRP1[1].$PAYLOAD_IY=0.000000 ;
 132:  $PLST_GRP1[1].$PAYLOAD_IZ=0.058162 ;
 133:  PAYLOAD[1] ;
 134:  !workcells/paper_fig9/programs/ro ;
 135:  !bot.yaml:19: move to ;
 136:  !table.slot_assembly (linear) ;
 137:L P[6] 250mm/sec FINE ;
 138:  !UTOOL[3] is robot.tool_plate ;
 139:  PR[90]=LPOS-LPOS ;
 140:  PR[90,1]=0.000000 ;
 141:  PR[90,2]=0.000000 ;
 142:  PR[90,3]=10.000000 ;
 143:  PR[90,4]=0.000000 ;
 144:  PR[90,5]=0.000000 ;
 145:  PR[90,6]=0.000000 ;
 146:  UTOOL[3]=PR[90] ;
 147:  UTOOL_NUM=3 ;
 148:  !workcells/paper_fig9/programs/ro ;
 149:  !bot.yaml:20: move to home ;
 150:J P[7] 100% FINE ;
 151:  !workcells/paper_fig9/programs/ro ;
 152:  !bot.yaml:21: move to ;
 153:  !tool_rack.hand_a_slot ;
 154:J P[8] 100% FINE ;
 155:  !workcells/paper_fig9/programs/ro ;
 156:  !bot.yaml:22: move to ;
 157:  !tool_rack.hand_a_slot (linear) ;
 158:L P[9] 116mm/sec FINE ;
 159:  !workcells/paper_fig9/programs/ro ;
 160:  !bot.yaml:23: detach_tool hand_a ;
 161:  DO[2]=OFF ;
 162:  !load on the flange: hand_b 0.3 ;
 163:  !kg ;
 164:  !kg, cm, kgf cm s^2, flange axes ;
 165:  $PLST_GRP1[1].$PAYLOAD=0.300000 ;
 166:  $PLST_GRP1[1].$PAYLOAD_X=0.000000 ;
 167:  $PLST_GRP1[1].$PAYLOAD_Y=-9.000000 ;
 168:  $PLST_GRP1[1].$PAYLOAD_Z=4.464102 ;
 169:  $PLST_GRP1[1].$PAYLOAD_IX=0.000000 ;
 170:  $PLST_GRP1[1].$PAYLOAD_IY=0.000000 ;
 171:  $PLST_GRP1[1].$PAYLOAD_IZ=0.000000 ;
 172:  PAYLOAD[1] ;
 173:  !workcells/paper_fig9/programs/ro ;
 174:  !bot.yaml:24: move to ;
 175:  !tool_rack.hand_a_slot (linear) ;
 176:L P[10] 232mm/sec FINE ;
 177:  !workcells/paper_fig9/programs/ro ;
 178:  !bot.yaml:25: move to home ;
 179:J P[11] 100% FINE ;
/POS
P[1]{
   GP1:
	UF : 0, UT : 1,
	J1=  -97.367772 deg,	J2=  -90.249676 deg,	J3=   72.673649 deg,
	J4= -102.218707 deg,	J5=  -86.323736 deg,	J6=   -6.389463 deg
};
P[2]{
   GP1:
	UF : 0, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =   -50.000000  mm,	Y =   449.999997  mm,	Z =   325.000000  mm,
	W =   180.000000 deg,	P =     0.000000 deg,	R =     0.000000 deg
};
P[3]{
   GP1:
	UF : 0, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =   -50.000000  mm,	Y =   449.999997  mm,	Z =   444.999999  mm,
	W =  -180.000000 deg,	P =     0.000000 deg,	R =     0.000000 deg
};
P[4]{
   GP1:
	UF : 0, UT : 2,
	J1= -122.711101 deg,	J2=  -82.354221 deg,	J3=   43.586800 deg,
	J4=  -25.322744 deg,	J5= -105.676268 deg,	J6=  -29.083486 deg
};
P[5]{
   GP1:
	UF : 0, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   149.999998  mm,	Y =   449.999997  mm,	Z =   329.999999  mm,
	W =   180.000000 deg,	P =     0.000000 deg,	R =     0.000000 deg
};
P[6]{
   GP1:
	UF : 0, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   149.999997  mm,	Y =   449.999996  mm,	Z =   479.999994  mm,
	W =  -180.000000 deg,	P =     0.000000 deg,	R =     0.000000 deg
};
P[7]{
   GP1:
	UF : 0, UT : 3,
	J1=    0.000000 deg,	J2=  -90.000000 deg,	J3=   90.000000 deg,
	J4=  -90.000000 deg,	J5=  -90.000000 deg,	J6=    0.000000 deg
};
P[8]{
   GP1:
	UF : 0, UT : 3,
	J1=  -78.553400 deg,	J2= -155.057698 deg,	J3=   25.775549 deg,
	J4=   39.282149 deg,	J5=  -90.000000 deg,	J6=   11.446600 deg
};
P[9]{
   GP1:
	UF : 0, UT : 3,		CONFIG : 'N U B, 0, 0, 0',
	X =    -0.000001  mm,	Y =  -549.999997  mm,	Z =   380.000000  mm,
	W =  -180.000000 deg,	P =     0.000000 deg,	R =     0.000000 deg
};
P[10]{
   GP1:
	UF : 0, UT : 3,		CONFIG : 'N U B, 0, 0, 0',
	X =    -0.000002  mm,	Y =  -549.999992  mm,	Z =   479.999995  mm,
	W =  -180.000000 deg,	P =     0.000000 deg,	R =     0.000000 deg
};
P[11]{
   GP1:
	UF : 0, UT : 3,
	J1=    0.000000 deg,	J2=  -90.000000 deg,	J3=   90.000000 deg,
	J4=  -90.000000 deg,	J5=  -90.000000 deg,	J6=    0.000000 deg
};
/END
