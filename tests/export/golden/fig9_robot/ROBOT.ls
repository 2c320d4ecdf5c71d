/PROG  ROBOT
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "rworld";
PROG_SIZE	= 0;
CREATE		= DATE 00-01-01  TIME 00:00:00;
MODIFIED	= DATE 00-01-01  TIME 00:00:00;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 178;
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
  24:  !frame values ;
  25:  !UFRAME 0: the world frame (the ;
  26:  !robot's base) ;
  27:  UFRAME_NUM=0 ;
  28:  !workcells/paper_fig9/programs/ro ;
  29:  !bot.yaml:7: sync arrived (at t = ;
  30:  !0.000 s in the simulation) ;
  31:  !load on the flange: hand_a, ;
  32:  !hand_b, shaft, cap 0.9 kg\x3b ;
  33:  !part, housing 1.12 kg ;
  34:  !products of inertia dropped: ;
  35:  !FANUC takes IX, IY, IZ only ;
  36:  !kg, cm, kgf cm s^2, flange axes ;
  37:  $PLST_GRP1[1].$PAYLOAD=2.020000 ;
  38:  $PLST_GRP1[1].$PAYLOAD_X=0.000000 ;
  39:  $PLST_GRP1[1].$PAYLOAD_Y=-5.304308 ;
  40:  $PLST_GRP1[1].$PAYLOAD_Z=9.480962 ;
  41:  $PLST_GRP1[1].$PAYLOAD_IX=0.264391 ;
  42:  $PLST_GRP1[1].$PAYLOAD_IY=0.029935 ;
  43:  $PLST_GRP1[1].$PAYLOAD_IZ=0.239962 ;
  44:  PAYLOAD[1] ;
  45:  !UTOOL[1] is hand_a.tcp ;
  46:  PR[90]=LPOS-LPOS ;
  47:  PR[90,1]=0.000000 ;
  48:  PR[90,2]=130.000000 ;
  49:  PR[90,3]=113.923048 ;
  50:  PR[90,4]=-30.000000 ;
  51:  PR[90,5]=0.000000 ;
  52:  PR[90,6]=0.000000 ;
  53:  UTOOL[1]=PR[90] ;
  54:  UTOOL_NUM=1 ;
  55:  !workcells/paper_fig9/programs/ro ;
  56:  !bot.yaml:8: move to ;
  57:  !table.slot_part ;
  58:J P[1] 100% FINE ;
  59:  !workcells/paper_fig9/programs/ro ;
  60:  !bot.yaml:9: move to ;
  61:  !table.slot_part (linear) ;
  62:L P[2] 125mm/sec FINE ;
  63:  !workcells/paper_fig9/programs/ro ;
  64:  !bot.yaml:10: place part on table ;
  65:  DO[1]=OFF ;
  66:  !workcells/paper_fig9/programs/ro ;
  67:  !bot.yaml:11: sync part_placed ;
  68:  !(at t = 4.626 s in the ;
  69:  !simulation) ;
  70:  !workcells/paper_fig9/programs/ro ;
  71:  !bot.yaml:12: sync hand_a_open ;
  72:  !(at t = 4.626 s in the ;
  73:  !simulation) ;
  74:  !load on the flange: hand_a, ;
  75:  !hand_b, shaft, cap 0.9 kg\x3b ;
  76:  !housing 0.8 kg ;
  77:  !products of inertia dropped: ;
  78:  !FANUC takes IX, IY, IZ only ;
  79:  !kg, cm, kgf cm s^2, flange axes ;
  80:  $PLST_GRP1[1].$PAYLOAD=1.700000 ;
  81:  $PLST_GRP1[1].$PAYLOAD_X=0.000000 ;
  82:  $PLST_GRP1[1].$PAYLOAD_Y=-8.411765 ;
  83:  $PLST_GRP1[1].$PAYLOAD_Z=9.405541 ;
  84:  $PLST_GRP1[1].$PAYLOAD_IX=0.151858 ;
  85:  $PLST_GRP1[1].$PAYLOAD_IY=0.024402 ;
  86:  $PLST_GRP1[1].$PAYLOAD_IZ=0.132147 ;
  87:  PAYLOAD[1] ;
  88:  !workcells/paper_fig9/programs/ro ;
  89:  !bot.yaml:13: move to ;
  90:  !table.slot_part (linear) ;
  91:L P[3] 250mm/sec FINE ;
  92:  !UTOOL[2] is hand_b.tcp ;
  93:  PR[90]=LPOS-LPOS ;
  94:  PR[90,1]=0.000000 ;
  95:  PR[90,2]=-130.000000 ;
  96:  PR[90,3]=113.923048 ;
  97:  PR[90,4]=30.000000 ;
  98:  PR[90,5]=0.000000 ;
  99:  PR[90,6]=0.000000 ;
 100:  UTOOL[2]=PR[90] ;
 101:  UTOOL_NUM=2 ;
 102:  !workcells/paper_fig9/programs/ro ;
 103:  !bot.yaml:14: move to ;
 104:  !table.slot_assembly ;
 105:J P[4] 100% FINE ;
 106:  !workcells/paper_fig9/programs/ro ;
 107:  !bot.yaml:15: move to ;
 108:  !table.slot_assembly (linear) ;
 109:L P[5] 125mm/sec FINE ;
 110:  !workcells/paper_fig9/programs/ro ;
 111:  !bot.yaml:16: place housing on ;
 112:  !table ;
 113:  DO[1]=OFF ;
 114:  !workcells/paper_fig9/programs/ro ;
 115:  !bot.yaml:17: sync housing_placed ;
 116:  !(at t = 7.952 s in the ;
 117:  !simulation) ;
 118:  !workcells/paper_fig9/programs/ro ;
 119:  !bot.yaml:18: sync hand_b_open ;
 120:  !(at t = 7.952 s in the ;
 121:  !simulation) ;
 122:  !load on the flange: hand_a, ;
 123:  !hand_b 0.6 kg ;
 124:  !kg, cm, kgf cm s^2, flange axes ;
 125:  $PLST_GRP1[1].$PAYLOAD=0.600000 ;
 126:  $PLST_GRP1[1].$PAYLOAD_X=0.000000 ;
 127:  $PLST_GRP1[1].$PAYLOAD_Y=0.000023 ;
 128:  $PLST_GRP1[1].$PAYLOAD_Z=5.763100 ;
 129:  $PLST_GRP1[1].$PAYLOAD_IX=0.058162 ;
 130:  $PLST_GRP1[1].$PAYLOAD_IY=0.000000 ;
 131:  $PLST_GRP1[1].$PAYLOAD_IZ=0.058162 ;
 132:  PAYLOAD[1] ;
 133:  !workcells/paper_fig9/programs/ro ;
 134:  !bot.yaml:19: move to ;
 135:  !table.slot_assembly (linear) ;
 136:L P[6] 250mm/sec FINE ;
 137:  !UTOOL[3] is robot.tool_plate ;
 138:  PR[90]=LPOS-LPOS ;
 139:  PR[90,1]=0.000000 ;
 140:  PR[90,2]=0.000000 ;
 141:  PR[90,3]=10.000000 ;
 142:  PR[90,4]=0.000000 ;
 143:  PR[90,5]=0.000000 ;
 144:  PR[90,6]=0.000000 ;
 145:  UTOOL[3]=PR[90] ;
 146:  UTOOL_NUM=3 ;
 147:  !workcells/paper_fig9/programs/ro ;
 148:  !bot.yaml:20: move to home ;
 149:J P[7] 100% FINE ;
 150:  !workcells/paper_fig9/programs/ro ;
 151:  !bot.yaml:21: move to ;
 152:  !tool_rack.hand_a_slot ;
 153:J P[8] 100% FINE ;
 154:  !workcells/paper_fig9/programs/ro ;
 155:  !bot.yaml:22: move to ;
 156:  !tool_rack.hand_a_slot (linear) ;
 157:L P[9] 116mm/sec FINE ;
 158:  !workcells/paper_fig9/programs/ro ;
 159:  !bot.yaml:23: detach_tool hand_a ;
 160:  DO[2]=OFF ;
 161:  !load on the flange: hand_b 0.3 ;
 162:  !kg ;
 163:  !kg, cm, kgf cm s^2, flange axes ;
 164:  $PLST_GRP1[1].$PAYLOAD=0.300000 ;
 165:  $PLST_GRP1[1].$PAYLOAD_X=0.000000 ;
 166:  $PLST_GRP1[1].$PAYLOAD_Y=-9.000000 ;
 167:  $PLST_GRP1[1].$PAYLOAD_Z=4.464102 ;
 168:  $PLST_GRP1[1].$PAYLOAD_IX=0.000000 ;
 169:  $PLST_GRP1[1].$PAYLOAD_IY=0.000000 ;
 170:  $PLST_GRP1[1].$PAYLOAD_IZ=0.000000 ;
 171:  PAYLOAD[1] ;
 172:  !workcells/paper_fig9/programs/ro ;
 173:  !bot.yaml:24: move to ;
 174:  !tool_rack.hand_a_slot (linear) ;
 175:L P[10] 232mm/sec FINE ;
 176:  !workcells/paper_fig9/programs/ro ;
 177:  !bot.yaml:25: move to home ;
 178:J P[11] 100% FINE ;
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
