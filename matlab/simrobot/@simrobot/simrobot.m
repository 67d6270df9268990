function r = simrobot(s)
% SIMROBOT  A robot as its control algorithm sees it (the original's @simrobot object).
%   r = simrobot(s) wraps the state struct s the world passes in every step. Algorithms do not
%   build robots: they receive one, call the methods listed in "help simrobot_commands"
%   (readusonic, readlaser, setvel, getpos, gethead, ...) and return it:
%
%     function new = alg(simrobot, matrix, step)
%       [dist, num] = readusonic(simrobot, 'sens1', matrix);
%       if dist < 20
%         simrobot = setvel(simrobot, [0 0.5]);
%       else
%         simrobot = setvel(simrobot, [0.5 0.5]);
%       end
%       new = simrobot;
%
%   Fields (private, as the original's): name, number, af, position [x y] (cells), heading
%   (degrees), velocity and accel [left right], power, crashed, userdata, sensors.
  if nargin == 1 && isa(s, 'simrobot')
    r = s;
    return
  end
  r = class(s, 'simrobot');
end
