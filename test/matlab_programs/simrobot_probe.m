function new = simrobot_probe(simrobot, matrix, step)
% SIMROBOT_PROBE  Keeps what the robot functions return in the robot's memory, then turns in
% place and at step 3 switches its robot off.
m = readmem(simrobot);
printf('probe step %d\n', step);
[dist, num] = readusonic(simrobot, 'front', matrix);
[data, nums] = readlaser(simrobot, 'scan', matrix);
m(step).pos = getpos(simrobot);
m(step).head = gethead(simrobot);
m(step).name = getname(simrobot);
m(step).num = getnum(simrobot);
m(step).dist = dist;
m(step).obstacle = num;
m(step).laser = data;
m(step).laser_nums = nums;
m(step).vel = getvel(simrobot);
m(step).power = getpower(simrobot);
m(step).size = size(matrix);
m(step).class = class(matrix);
m(step).own_cells = find(matrix == getnum(simrobot))';
[l, r] = invmodel(1, 0.5);
m(step).inv = [l r];
try
  readusonic(simrobot, 'nosuch', matrix);
catch err
  m(step).unknown = err.message;
end
simrobot = writemem(simrobot, m);
simrobot = setvel(simrobot, [-0.5 0.5]);
if step == 3
  simrobot = setpower(simrobot, 'off');
end
new = simrobot;
