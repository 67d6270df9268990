function create_long_travel(serPort)
% CREATE_LONG_TRAVEL  One travelDist of 5 m at 0.1 m/s: the program is killed inside the call.
travelDist(serPort, 0.1, 5);
end
