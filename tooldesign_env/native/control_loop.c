/*
 * The control loop of tooldesign_env.simulation.ToolSimulator, as a PyBullet plugin.
 *
 * A rollout makes about 8 requests to the physics server per control step (the torque command
 * and the physics step twice, the arm's state, the box's state, the contact manifold, the
 * inverse dynamics). From Python each costs 2-5 us of argument parsing and tuple building on
 * top of what the server does; from here it costs what the server does. The loop below makes
 * the same requests, in the same order, with the same arguments, and the same floating-point
 * operations as the Python loop, so its results are the same bit for bit
 * (tests/test_native_loop.py compares every recorded series).
 *
 * How it is reached: PyBullet loads a plugin with dlopen and calls executePluginCommand_<postfix>
 * inside its server, handing it a physics client connected to that server
 * (b3PluginContext.m_physClient). Through it this file calls PyBullet's own C API, which
 * PyBullet's shared library exports; the "bind" command resolves those functions by name from
 * that library (dlopen with RTLD_NOLOAD: the library is already loaded, nothing is promoted to
 * the global namespace). Bulk data travels through memory owned by the Python caller: the
 * integer arguments of a command carry the address of a struct loop_args (two 32-bit halves),
 * because PyBullet passes plugin float arguments as C floats.
 *
 * ABI: the declarations below are this file's own, written for PyBullet's C API of
 * SHARED_MEMORY_MAGIC_NUMBER 202010061 (PyBullet 3.2.x). initPlugin returns that number and
 * PyBullet refuses a plugin whose number differs from its own, so a PyBullet with another
 * layout does not load this plugin; the Python side then runs its own loop.
 *
 * Built as an optional extension by setup.py; the C compiler must not fuse a * b + c into one
 * rounding (-ffp-contract=off), or the controller's torques would differ from Python's.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define TOOLDESIGN_ABI_MAGIC 202010061
/* Bumped whenever a command or struct loop_args changes: the Python side refuses a library
 * built from another version of this file (a stale build of an editable install). */
#define LOOP_VERSION 3

/* Status codes of PyBullet's server (EnumSharedMemoryServerStatus of that ABI). */
enum {
    STATUS_ACTUAL_STATE = 21,
    STATUS_DESIRED_STATE = 25,
    STATUS_STEP = 26,
    STATUS_INVERSE_DYNAMICS = 33,
    STATUS_JACOBIAN = 35,
    STATUS_MASS_MATRIX = 37,
    STATUS_CONTACT_POINTS = 39,
    STATUS_SYNC_BODY_INFO = 66,
    STATUS_SAVE_STATE = 93,
};
enum { CONTROL_MODE_TORQUE = 1 };

typedef struct opaque_client *client_t;
typedef struct opaque_command *command_t;
typedef struct opaque_status *status_t;

struct plugin_context { /* the first two fields of b3PluginContext */
    client_t client;
    void *user_pointer;
};

struct plugin_arguments { /* b3PluginArguments */
    char text[1024];
    int num_ints;
    int ints[128];
    int num_floats;
    double floats[128];
};

struct link_state { /* b3LinkState */
    double world_position[3];
    double world_orientation[4];
    double local_inertial_position[3];
    double local_inertial_orientation[4];
    double world_link_frame_position[3];
    double world_link_frame_orientation[4];
    double world_linear_velocity[3];
    double world_angular_velocity[3];
    double world_aabb_min[3];
    double world_aabb_max[3];
};

struct contact_point { /* b3ContactPointData */
    int flags;
    int body_a, body_b, link_a, link_b;
    double position_on_a[3];
    double position_on_b[3];
    double normal_on_b[3];
    double distance;
    double normal_force;
    double friction_force[2];
    double friction_direction[2][3];
};

struct contact_information { /* b3ContactInformation */
    int count;
    struct contact_point *points;
};

/* PyBullet's C API, resolved by "bind". */
static struct {
    status_t (*submit)(client_t, command_t);
    int (*status_type)(status_t);
    command_t (*step)(client_t);
    command_t (*torque_command)(client_t, int body, int mode);
    int (*set_torque)(command_t, int dof, double value);
    command_t (*state_request)(client_t, int body);
    int (*state_forward_kinematics)(command_t, int compute);
    int (*actual_state)(status_t, int *body, int *nq, int *nu, const double **inertial,
                        const double **q, const double **qd, const double **reaction);
    int (*link_state)(client_t, status_t, int link, struct link_state *);
    command_t (*inverse_dynamics)(client_t, int body, const double *q, int nq,
                                  const double *qd, const double *qdd, int nu);
    void (*inverse_dynamics_flags)(command_t, int flags);
    int (*inverse_dynamics_forces)(status_t, int *body, int *dofs, double *forces);
    command_t (*contact_request)(client_t);
    void (*contact_body_a)(command_t, int);
    void (*contact_body_b)(command_t, int);
    void (*contact_link_a)(command_t, int);
    void (*contact_link_b)(command_t, int);
    void (*contact_information)(client_t, struct contact_information *);
    command_t (*jacobian)(client_t, int body, int link, const double *local, const double *q,
                          const double *qd, const double *qdd);
    int (*jacobian_result)(status_t, int *dofs, double *linear, double *angular);
    command_t (*mass_matrix)(client_t, int body, const double *q, int nq);
    void (*mass_matrix_flags)(command_t, int flags);
    int (*mass_matrix_result)(client_t, status_t, int *dofs, double *matrix);
    command_t (*save_state)(client_t);
    int (*state_id)(status_t);
    command_t (*sync_bodies)(client_t);
    int (*dof_count)(client_t, int body);
} api;
static int api_bound = 0;

#define ARM 7
#define MAX_DEGREE_OF_FREEDOM 128 /* the length of PyBullet's state vectors */

/* Error codes returned to Python (tooldesign_env.native.ERRORS names them); far from -1, which
 * PyBullet itself answers for a plugin id it does not know. */
enum {
    ERR_NOT_BOUND = -1001,
    ERR_BAD_ARGUMENTS = -1002,
    ERR_UNKNOWN_COMMAND = -1003,
    ERR_STEP = -1004,
    ERR_MOTOR = -1005,
    ERR_STATE = -1006,
    ERR_INVERSE_DYNAMICS = -1007,
    ERR_CONTACTS = -1008,
    ERR_JACOBIAN = -1009,
    ERR_MASS_MATRIX = -1010,
    ERR_SAVE_STATE = -1011,
    ERR_MEMORY = -1012,
    ERR_LIBRARY = -1013,
    ERR_SYMBOL = -1014,
    ERR_SYNC = -1015,
};

/* What one rollout reads and writes; mirrored by tooldesign_env.native.loop.LoopArgs. Arrays
 * are C-contiguous float64 (or int32, int8) with n rows unless said otherwise. */
struct loop_args {
    /* inputs */
    const double *qdd_ref, *q_ref, *qd_ref; /* (n, 7) the plan's references */
    const int8_t *phase;                    /* (n,) index of each step's plan segment */
    const double *torques_in;               /* (n, 7) for "replay" only */
    double kp, kd;                          /* feedback gains, 1/s^2 and 1/s */
    double torque_limit[ARM];               /* N m */
    double rest_speed;                      /* m/s and rad/s */
    int32_t robot, box, ee_link, tool_link;
    int32_t q_index[ARM], u_index[ARM];     /* the arm joints' slots in PyBullet's state */
    int32_t n, period;                      /* control steps; physics steps per control step */
    int32_t record_mobility;                /* record the contact manifold's points */
    int32_t fast_forward, hold_phase, hold_from, rest_needed;
    int32_t snapshot_every;                 /* 0: none */
    /* outputs */
    double *torques, *q, *qd;               /* (n, 7) */
    double *box_position;                   /* (n, 3) */
    double *ee_position;                    /* (n, 3) grasp frame origin */
    double *ee_orientation;                 /* (n, 4) grasp frame quaternion (x, y, z, w) */
    double *tool_com;                       /* (n, 3) tool link's centre of mass, at logged steps */
    int32_t *contact_points;                /* (n,) points in the tool-box manifold */
    int32_t *snapshot_ids;                  /* (n / snapshot_every + 2,) PyBullet state ids */
    double *jacobians;                      /* "arm_matrices": (n, 2, 3, 7) linear, angular */
    double *mass_matrices;                  /* "arm_matrices": (n, 7, 7) */
    int32_t steps;                          /* control steps simulated */
    int32_t fast_forward_from;              /* n when nothing was fast-forwarded */
    int32_t logged_points;                  /* points kept for "contacts" */
    int32_t snapshots;                      /* ids written to snapshot_ids */
};

/* Points of the contact manifold kept during the last rollout of a world (one per server). */
struct world_data {
    double *points; /* (capacity, 6): position on the tool, normal on the tool, world frame */
    int32_t count, capacity;
};

int initPlugin_tooldesign(struct plugin_context *context) {
    struct world_data *data = calloc(1, sizeof(struct world_data));
    context->user_pointer = data;
    return data ? TOOLDESIGN_ABI_MAGIC : -1;
}

void exitPlugin_tooldesign(struct plugin_context *context) {
    struct world_data *data = context->user_pointer;
    if (data) {
        free(data->points);
        free(data);
    }
    context->user_pointer = NULL;
}

static void *address(const struct plugin_arguments *arguments, int first) {
    uint64_t low = (uint32_t)arguments->ints[first], high = (uint32_t)arguments->ints[first + 1];
    return (void *)(uintptr_t)((high << 32) | low);
}

static int bind(const char *path) {
    /* Resolved into a table of its own and published only when complete: a failed bind must
     * not leave a NULL in the table an earlier bind filled. */
    __typeof__(api) table;
    api_bound = 0;
    void *library = dlopen(path, RTLD_LAZY | RTLD_NOLOAD);
    if (!library) return ERR_LIBRARY;
#define BIND(field, name)                                              \
    do {                                                               \
        *(void **)(&table.field) = dlsym(library, name);               \
        if (!table.field) {                                            \
            dlclose(library);                                          \
            return ERR_SYMBOL;                                         \
        }                                                              \
    } while (0)
    BIND(submit, "b3SubmitClientCommandAndWaitStatus");
    BIND(status_type, "b3GetStatusType");
    BIND(step, "b3InitStepSimulationCommand");
    BIND(torque_command, "b3JointControlCommandInit2");
    BIND(set_torque, "b3JointControlSetDesiredForceTorque");
    BIND(state_request, "b3RequestActualStateCommandInit");
    BIND(state_forward_kinematics, "b3RequestActualStateCommandComputeForwardKinematics");
    BIND(actual_state, "b3GetStatusActualState");
    BIND(link_state, "b3GetLinkState");
    BIND(inverse_dynamics, "b3CalculateInverseDynamicsCommandInit2");
    BIND(inverse_dynamics_flags, "b3CalculateInverseDynamicsSetFlags");
    BIND(inverse_dynamics_forces, "b3GetStatusInverseDynamicsJointForces");
    BIND(contact_request, "b3InitRequestContactPointInformation");
    BIND(contact_body_a, "b3SetContactFilterBodyA");
    BIND(contact_body_b, "b3SetContactFilterBodyB");
    BIND(contact_link_a, "b3SetContactFilterLinkA");
    BIND(contact_link_b, "b3SetContactFilterLinkB");
    BIND(contact_information, "b3GetContactPointInformation");
    BIND(jacobian, "b3CalculateJacobianCommandInit");
    BIND(jacobian_result, "b3GetStatusJacobian");
    BIND(mass_matrix, "b3CalculateMassMatrixCommandInit");
    BIND(mass_matrix_flags, "b3CalculateMassMatrixSetFlags");
    BIND(mass_matrix_result, "b3GetStatusMassMatrix");
    BIND(save_state, "b3SaveStateCommandInit");
    BIND(state_id, "b3GetStatusGetStateId");
    BIND(sync_bodies, "b3InitSyncBodyInfoCommand");
    BIND(dof_count, "b3ComputeDofCount");
#undef BIND
    /* The library stays loaded by PyBullet; this reference is dropped, the symbols stay valid. */
    dlclose(library);
    api = table;
    api_bound = 1;
    return 0;
}

/* pybullet.setJointMotorControlArray(robot, joints, TORQUE_CONTROL, forces=torque), then
 * pybullet.stepSimulation(), `period` times. */
static int apply_and_step(client_t client, const struct loop_args *a, const double *torque) {
    for (int s = 0; s < a->period; s++) {
        command_t command = api.torque_command(client, a->robot, CONTROL_MODE_TORQUE);
        for (int j = 0; j < ARM; j++) api.set_torque(command, a->u_index[j], torque[j]);
        if (api.status_type(api.submit(client, command)) != STATUS_DESIRED_STATE) return ERR_MOTOR;
        if (api.status_type(api.submit(client, api.step(client))) != STATUS_STEP) return ERR_STEP;
    }
    return 0;
}

/* The arm's state: q and qd of the 7 joints (pybullet.getJointStates), with forward kinematics
 * computed as pybullet.getLinkState(..., computeForwardKinematics=1) does. Forward kinematics
 * only refreshes the links' cached frames from q, so reading the joints from the same request
 * reads what getJointStates would. */
static status_t arm_state(client_t client, const struct loop_args *a, double *q, double *qd) {
    command_t command = api.state_request(client, a->robot);
    api.state_forward_kinematics(command, 1);
    status_t status = api.submit(client, command);
    if (api.status_type(status) != STATUS_ACTUAL_STATE) return NULL;
    const double *all_q = NULL, *all_qd = NULL;
    api.actual_state(status, NULL, NULL, NULL, NULL, &all_q, &all_qd, NULL);
    if (!all_q || !all_qd) return NULL;
    for (int j = 0; j < ARM; j++) {
        q[j] = all_q[a->q_index[j]];
        qd[j] = all_qd[a->u_index[j]];
    }
    return status;
}

/* The box's base position (pybullet.getBasePositionAndOrientation) and linear velocity
 * (pybullet.getBaseVelocity), from one request. */
static int box_state(client_t client, const struct loop_args *a, double *position, double *velocity) {
    status_t status = api.submit(client, api.state_request(client, a->box));
    if (api.status_type(status) != STATUS_ACTUAL_STATE) return ERR_STATE;
    const double *q = NULL, *qd = NULL;
    api.actual_state(status, NULL, NULL, NULL, NULL, &q, &qd, NULL);
    if (!q || !qd) return ERR_STATE;
    for (int i = 0; i < 3; i++) {
        position[i] = q[i];
        velocity[i] = qd[i];
    }
    return 0;
}

/* pybullet.getContactPoints(box, robot, -1, tool_link). */
static int contacts(client_t client, const struct loop_args *a, struct contact_information *info) {
    command_t command = api.contact_request(client);
    api.contact_body_a(command, a->box);
    api.contact_body_b(command, a->robot);
    api.contact_link_a(command, -1);
    api.contact_link_b(command, a->tool_link);
    if (api.status_type(api.submit(client, command)) != STATUS_CONTACT_POINTS) return ERR_CONTACTS;
    api.contact_information(client, info);
    return 0;
}

static int save_state(client_t client, int32_t *id) {
    status_t status = api.submit(client, api.save_state(client));
    if (api.status_type(status) != STATUS_SAVE_STATE) return ERR_SAVE_STATE;
    *id = api.state_id(status);
    return 0;
}

static int keep_points(struct world_data *data, const struct contact_information *info) {
    if (data->count + info->count > data->capacity) {
        int32_t capacity = data->capacity ? data->capacity : 1024;
        while (capacity < data->count + info->count) capacity *= 2;
        double *grown = realloc(data->points, sizeof(double) * 6 * (size_t)capacity);
        if (!grown) return ERR_MEMORY;
        data->points = grown;
        data->capacity = capacity;
    }
    for (int i = 0; i < info->count; i++) {
        double *row = data->points + 6 * (size_t)(data->count + i);
        memcpy(row, info->points[i].position_on_b, 3 * sizeof(double));
        memcpy(row + 3, info->points[i].normal_on_b, 3 * sizeof(double));
    }
    data->count += info->count;
    return 0;
}

/* The rollout: ToolSimulator._run's loop, step for step. */
static int rollout(client_t client, struct world_data *data, struct loop_args *a) {
    double q[ARM], qd[ARM], qdd[ARM], force[ARM], box_velocity[3];
    int at_rest = 0, error;
    data->count = 0;
    a->steps = 0;
    a->fast_forward_from = a->n;
    a->logged_points = 0;
    a->snapshots = 0;
    if (!arm_state(client, a, q, qd)) return ERR_STATE;
    for (int k = 0; k < a->n; k++) {
        if (a->snapshot_every > 0 && k % a->snapshot_every == 0) {
            if ((error = save_state(client, &a->snapshot_ids[a->snapshots]))) return error;
            a->snapshots++;
        }
        const size_t row = (size_t)k * ARM;
        const double *qdd_ref = a->qdd_ref + row, *q_ref = a->q_ref + row;
        const double *qd_ref = a->qd_ref + row;
        for (int j = 0; j < ARM; j++)
            qdd[j] = qdd_ref[j] + a->kp * (q_ref[j] - q[j]) + a->kd * (qd_ref[j] - qd[j]);
        /* pybullet.calculateInverseDynamics(robot, q, qd, qdd) */
        command_t command = api.inverse_dynamics(client, a->robot, q, ARM, qd, qdd, ARM);
        api.inverse_dynamics_flags(command, 0);
        status_t status = api.submit(client, command);
        if (api.status_type(status) != STATUS_INVERSE_DYNAMICS) return ERR_INVERSE_DYNAMICS;
        int dofs = 0;
        api.inverse_dynamics_forces(status, NULL, &dofs, NULL);
        if (dofs != ARM) return ERR_INVERSE_DYNAMICS;
        api.inverse_dynamics_forces(status, NULL, NULL, force);
        double *torque = a->torques + row;
        for (int j = 0; j < ARM; j++) {
            double t = force[j], limit = a->torque_limit[j];
            torque[j] = t < -limit ? -limit : (t > limit ? limit : t);
        }
        if ((error = apply_and_step(client, a, torque))) return error;
        double *q_row = a->q + row, *qd_row = a->qd + row;
        status = arm_state(client, a, q_row, qd_row);
        if (!status) return ERR_STATE;
        memcpy(q, q_row, sizeof q);
        memcpy(qd, qd_row, sizeof qd);
        /* The status lives in the client's one buffer, which the next request overwrites: the
         * link states are read now (the tool's is used only if the tool touches the box). */
        struct link_state ee, tool;
        if (!api.link_state(client, status, a->ee_link, &ee)) return ERR_STATE;
        if (a->record_mobility && !api.link_state(client, status, a->tool_link, &tool))
            return ERR_STATE;
        if ((error = box_state(client, a, a->box_position + 3 * (size_t)k, box_velocity))) return error;
        struct contact_information info = {0, NULL};
        if ((error = contacts(client, a, &info))) return error;
        a->contact_points[k] = info.count;
        if (info.count > 0 && a->record_mobility) {
            memcpy(a->tool_com + 3 * (size_t)k, tool.world_position, 3 * sizeof(double));
            if ((error = keep_points(data, &info))) return error;
        }
        memcpy(a->ee_position + 3 * (size_t)k, ee.world_link_frame_position, 3 * sizeof(double));
        memcpy(a->ee_orientation + 4 * (size_t)k, ee.world_link_frame_orientation, 4 * sizeof(double));
        a->steps = k + 1;
        if (a->fast_forward && k >= a->hold_from && a->phase[k] == a->hold_phase) {
            double speed = sqrt(box_velocity[0] * box_velocity[0] +
                                box_velocity[1] * box_velocity[1] +
                                box_velocity[2] * box_velocity[2]);
            /* Python's max(map(abs, qd)): the first, replaced by any later one that is
             * greater (so a NaN first stays, and a later NaN is passed over). The speed is
             * sqrt(x x + y y + z z), where Python takes np.linalg.norm: the same on every
             * vector tried (they could differ in the last bit, which decides only a speed
             * within a bit of rest_speed). */
            double fastest = fabs(qd[0]);
            for (int j = 1; j < ARM; j++)
                if (fabs(qd[j]) > fastest) fastest = fabs(qd[j]);
            int still = speed < a->rest_speed && fastest < a->rest_speed;
            at_rest = still ? at_rest + 1 : 0;
            if (at_rest >= a->rest_needed && k + 1 < a->n) {
                a->fast_forward_from = k + 1;
                if (a->snapshot_every > 0) {
                    /* One snapshot of the rest state serves every fast-forwarded step. */
                    if ((error = save_state(client, &a->snapshot_ids[a->snapshots]))) return error;
                    a->snapshots++;
                }
                break;
            }
        }
    }
    a->logged_points = data->count;
    return 0;
}

/* Open loop: torques_in applied as in a rollout, no controller, the box's position recorded. */
static int replay(client_t client, struct loop_args *a) {
    double velocity[3];
    int error;
    a->steps = 0;
    for (int k = 0; k < a->n; k++) {
        if ((error = apply_and_step(client, a, a->torques_in + (size_t)k * ARM))) return error;
        if ((error = box_state(client, a, a->box_position + 3 * (size_t)k, velocity))) return error;
        a->steps = k + 1;
    }
    return 0;
}

/* The tool's centre-of-mass Jacobians (n, 2, 3, 7) and the mass matrices (n, 7, 7) at the n
 * joint positions a->q_ref (read only here), as pybullet.calculateJacobian(robot, tool_link, (0, 0, 0),
 * q, 0, 0) and pybullet.calculateMassMatrix(robot, q) return them, row-major. */
static int arm_matrices(client_t client, struct loop_args *a) {
    static const double origin[3] = {0.0, 0.0, 0.0};
    const double zeros[ARM] = {0.0};
    /* b3CalculateJacobianCommandInit copies as many joint positions as the client's cache of
     * the body's joints counts: a client that has not seen the robot copies none, and the
     * server computes the Jacobian at whatever positions its command buffer held. The plugin's
     * client did not load the robot, so it learns the bodies first, and checks. */
    if (api.status_type(api.submit(client, api.sync_bodies(client))) != STATUS_SYNC_BODY_INFO)
        return ERR_SYNC;
    if (api.dof_count(client, a->robot) != ARM) return ERR_SYNC;
    for (int k = 0; k < a->n; k++) {
        const double *q = a->q_ref + (size_t)k * ARM;
        status_t status = api.submit(
            client, api.jacobian(client, a->robot, a->tool_link, origin, q, zeros, zeros));
        if (api.status_type(status) != STATUS_JACOBIAN) return ERR_JACOBIAN;
        int dofs = 0;
        api.jacobian_result(status, &dofs, NULL, NULL);
        if (dofs != ARM) return ERR_JACOBIAN;
        double *jacobian = a->jacobians + (size_t)k * 2 * 3 * ARM;
        api.jacobian_result(status, NULL, jacobian, jacobian + 3 * ARM);
        command_t command = api.mass_matrix(client, a->robot, q, ARM);
        api.mass_matrix_flags(command, 0);
        status = api.submit(client, command);
        if (api.status_type(status) != STATUS_MASS_MATRIX) return ERR_MASS_MATRIX;
        api.mass_matrix_result(client, status, &dofs, NULL);
        if (dofs != ARM) return ERR_MASS_MATRIX;
        api.mass_matrix_result(client, status, NULL, a->mass_matrices + (size_t)k * ARM * ARM);
    }
    return 0;
}

/* The arm joints' slots in PyBullet's state vectors (a fixed joint has none: -1). */
static int valid_slots(const struct loop_args *a) {
    for (int j = 0; j < ARM; j++)
        if (a->q_index[j] < 0 || a->q_index[j] >= MAX_DEGREE_OF_FREEDOM || a->u_index[j] < 0 ||
            a->u_index[j] >= MAX_DEGREE_OF_FREEDOM)
            return 0;
    return 1;
}

/* Commands: "version" and "layout" (LOOP_VERSION, sizeof(struct loop_args)), "bind <path of
 * PyBullet's library>"; "rollout", "replay", "arm_matrices",
 * "contacts", each with the address of a struct loop_args in ints[0:2] (for "contacts": of a
 * (logged_points, 6) float64 array to fill, and its rows in ints[2]). Returns 0, or an ERR_* code. */
int executePluginCommand_tooldesign(struct plugin_context *context,
                                    const struct plugin_arguments *arguments) {
    struct world_data *data = context->user_pointer;
    if (strcmp(arguments->text, "version") == 0) return LOOP_VERSION;
    if (strcmp(arguments->text, "layout") == 0) return (int)sizeof(struct loop_args);
    if (strncmp(arguments->text, "bind ", 5) == 0) return bind(arguments->text + 5);
    const char *text = arguments->text;
    enum { CONTACTS, ROLLOUT, REPLAY, ARM_MATRICES } command;
    if (strcmp(text, "contacts") == 0) command = CONTACTS;
    else if (strcmp(text, "rollout") == 0) command = ROLLOUT;
    else if (strcmp(text, "replay") == 0) command = REPLAY;
    else if (strcmp(text, "arm_matrices") == 0) command = ARM_MATRICES;
    else return ERR_UNKNOWN_COMMAND;
    if (!api_bound) return ERR_NOT_BOUND;
    if (arguments->num_ints < 2 || !data) return ERR_BAD_ARGUMENTS;
    void *target = address(arguments, 0);
    if (!target) return ERR_BAD_ARGUMENTS;
    if (command == CONTACTS) {
        /* ints[2]: the rows of the target, which must be the rows kept */
        if (arguments->num_ints != 3 || arguments->ints[2] != data->count) return ERR_BAD_ARGUMENTS;
        if (data->count) memcpy(target, data->points, sizeof(double) * 6 * (size_t)data->count);
        return 0;
    }
    struct loop_args *a = target;
    if (a->n < 0 || a->period < 1) return ERR_BAD_ARGUMENTS;
    switch (command) {
        case ROLLOUT:
            if (!valid_slots(a) ||
                (a->n > 0 && !(a->qdd_ref && a->q_ref && a->qd_ref && a->phase && a->torques &&
                               a->q && a->qd && a->box_position && a->ee_position &&
                               a->ee_orientation && a->tool_com && a->contact_points &&
                               a->snapshot_ids)))
                return ERR_BAD_ARGUMENTS;
            return rollout(context->client, data, a);
        case REPLAY:
            if (!valid_slots(a) || (a->n > 0 && !(a->torques_in && a->box_position)))
                return ERR_BAD_ARGUMENTS;
            return replay(context->client, a);
        default: /* ARM_MATRICES */
            if (a->n > 0 && !(a->q_ref && a->jacobians && a->mass_matrices)) return ERR_BAD_ARGUMENTS;
            return arm_matrices(context->client, a);
    }
}
