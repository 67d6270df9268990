function create_bump_turn(serPort)
% CREATE_BUMP_TURN  Drive forward; on a bump back up 10 cm and turn 20 degrees left.
%   Stops after two bumps (or 30 s). A control program in the original's style: its Python
%   twin is create_bump_turn.py.
bumps = 0;
tic
while toc < 30 && bumps < 2
    [BumpRight, BumpLeft, ~, ~, ~, BumpFront] = BumpsWheelDropsSensorsRoomba(serPort);
    if BumpRight || BumpLeft || BumpFront
        bumps = bumps + 1;
        travelDist(serPort, 0.2, -0.1);
        turnAngle(serPort, 0.2, 20);
    else
        SetFwdVelAngVelCreate(serPort, 0.3, 0);
    end
    pause(0.05);
end
SetFwdVelAngVelCreate(serPort, 0, 0);
end
