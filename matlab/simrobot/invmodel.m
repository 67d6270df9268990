function [left_angular_vel, right_angular_vel] = invmodel(movspd, rotspd)
% INVMODEL  The inverse kinematic model: wheel speeds for a body velocity.
%   [left_angular_vel, right_angular_vel] = invmodel(movspd, rotspd)
%   movspd: the robot body's forward speed (cells/s, i.e. cm/s in the original's worlds);
%   rotspd: its rotation speed about z (rad/s, counter-clockwise positive).
%   Wheel speeds in rad/s for the original's robot: wheel radius R = 1 cell, half the wheel
%   distance la = 3 cells, axle offset lb = 0 (the world file's defaults). For a robot whose
%   world file sets other wheel_radius/half_track, compute (movspd -+ la*rotspd)/R yourself.
%   With one output, returns the vector [left right].
  R = 1;
  la = 3;
  left_angular_vel = (movspd - la * rotspd) / R;
  right_angular_vel = (movspd + la * rotspd) / R;
  if nargout <= 1
    left_angular_vel = [left_angular_vel right_angular_vel];
  end
end
