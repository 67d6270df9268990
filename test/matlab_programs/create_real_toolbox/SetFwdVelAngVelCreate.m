function SetFwdVelAngVelCreate(serPort, FwdVel, AngVel)
% SETFWDVELANGVELCREATE  Stands in for the real robot's toolbox function of this name, on the
%   path beside ours: a CreateRobot must never reach it.
error('real toolbox called with a %s', class(serPort));
end
