function create_wall_follower(serPort)
% CREATE_WALL_FOLLOWER  Follow the wall on the right at 0.25 m with the right sonar; turn left
%   in place while the front sonar sees a wall closer than 0.25 m (a corner). Runs for 5 s.
%   Its Python twin is create_wall_follower.py.
tic
while toc < 5
    right = sonar(serPort, 1);
    front = sonar(serPort, 2);
    if front < 0.25
        SetFwdVelAngVelCreate(serPort, 0, 0.6);
    else
        SetFwdVelAngVelCreate(serPort, 0.15, max(-0.8, min(0.8, -3 * (right - 0.25))));
    end
    pause(0.05);
end
SetFwdVelAngVelCreate(serPort, 0, 0);
end

function d = sonar(serPort, number)
% The toolbox's ReadSonar says [] with nothing in range (0.17 m or closer, 3 m or further):
% read that as 3 m, as the course's programs do.
d = ReadSonar(serPort, number);
if isempty(d)
    d = 3;
end
end
