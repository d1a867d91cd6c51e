import * as THREE from 'three';

const PALETTE = [ 0x2f6fd6, 0xf07a1a, 0x17a08f, 0x9b4dca, 0xd6405a, 0x6b8e23 ];
const TCP_RADIUS = 0.012;

const _hsl = { h: 0, s: 0, l: 0 };
const _box = new THREE.Box3();

function setPose( object, pose ) {

	object.position.set( pose[ 0 ], pose[ 1 ], pose[ 2 ] );
	object.quaternion.set( pose[ 3 ], pose[ 4 ], pose[ 5 ], pose[ 6 ] );

}

/**
 * One robot of the cell, built from its `robot` entry of `hello`: a Group at the
 * robot's base pose with one child Object3D per link (in hello order, carrying
 * that link's mesh, whose origin is the link frame) and a TCP marker. Frames
 * set the link and TCP poses, which are given in the robot base frame.
 */
class RobotView {

	constructor( robot, index ) {

		this.name = robot.name;
		this.info = robot;
		this.color = new THREE.Color( PALETTE[ index % PALETTE.length ] );

		this.group = new THREE.Group();
		this.group.name = robot.name;
		setPose( this.group, robot.base );
		// Hidden until the first good frame: before it every link sits at the base origin.
		this.group.visible = false;

		this.nodes = robot.links.map( ( link ) => {

			const node = new THREE.Object3D();
			node.name = link.name;
			this.group.add( node );
			return node;

		} );

		this.tcp = this._makeTcpMarker();
		this.group.add( this.tcp );

		this.framesApplied = 0;
		this.framesReceived = 0; // counted on arrival, before coalescing
		this.lastFrame = null; // newest frame, good or not
		this.goodFrame = null; // newest frame with ok = true: what the view shows
		this.error = null;
		this.anchor = null; // world point above the robot for its label

	}

	_makeTcpMarker() {

		const marker = new THREE.Group();
		marker.name = 'tcp';
		this._tcpMaterial = new THREE.MeshBasicMaterial( {
			color: this.color, depthTest: false, transparent: true, opacity: 0.9
		} );
		const ball = new THREE.Mesh( new THREE.SphereGeometry( TCP_RADIUS, 24, 12 ), this._tcpMaterial );
		ball.renderOrder = 10;
		const axes = new THREE.AxesHelper( 0.06 );
		axes.material.depthTest = false;
		axes.renderOrder = 11;
		marker.add( ball, axes );
		return marker;

	}

	/** Load every link mesh with `loadMesh(url) -> Promise<Object3D>`; resolves once all are in. */
	async load( loadMesh ) {

		const meshes = await Promise.all( this.info.links.map( ( link ) => loadMesh( link.mesh ) ) );
		meshes.forEach( ( mesh, i ) => {

			mesh.traverse( ( child ) => {

				if ( child.isMesh ) {

					child.castShadow = true;
					child.receiveShadow = true;

				}

			} );
			this.nodes[ i ].add( mesh );

		} );
		this._pickColor();

	}

	/**
	 * The robot's colour is the most saturated of its materials, weighted by the
	 * size of the parts wearing it, so HUD, label and TCP marker match the meshes.
	 */
	_pickColor() {

		const weights = new Map(); // material -> summed weight
		this.group.traverse( ( child ) => {

			if ( ! child.isMesh || ! child.material.color || child.parent === this.tcp ) return;
			child.material.color.getHSL( _hsl );
			if ( _hsl.s < 0.3 || _hsl.l < 0.08 ) return;
			if ( child.geometry.boundingSphere === null ) child.geometry.computeBoundingSphere();
			const radius = child.geometry.boundingSphere.radius;
			weights.set( child.material, ( weights.get( child.material ) || 0 ) + _hsl.s * radius * radius );

		} );
		let best = null;
		for ( const [ candidate, weight ] of weights ) if ( best === null || weight > weights.get( best ) ) best = candidate;
		if ( best ) this.color.copy( best.color );
		this._tcpMaterial.color.copy( this.color );

	}

	/** Apply `frame` (already the newest for this robot); a frame that is not ok keeps the last pose. */
	apply( frame ) {

		this.lastFrame = frame;
		if ( ! frame.ok ) {

			this.error = frame.error || 'the server could not compute this pose';
			return;

		}
		this.error = null;
		this.goodFrame = frame;
		const poses = frame.links;
		const count = Math.min( poses.length, this.nodes.length );
		for ( let i = 0; i < count; i ++ ) setPose( this.nodes[ i ], poses[ i ] );
		if ( frame.tcp.length === 7 ) setPose( this.tcp, frame.tcp );
		this.group.visible = true;
		this.framesApplied ++;

	}

	/** World matrices of the links (hello order), each as 16 numbers (column-major). */
	linkMatrices() {

		this.group.updateWorldMatrix( true, true );
		return this.nodes.map( ( node ) => Array.from( node.matrixWorld.elements ) );

	}

	/** Move the label's anchor to just above the robot's current bounding box (world frame). */
	updateAnchor() {

		if ( ! this.group.visible ) return;
		_box.setFromObject( this.group );
		if ( _box.isEmpty() ) return;
		if ( this.anchor === null ) this.anchor = new THREE.Vector3();
		this.anchor.set( ( _box.min.x + _box.max.x ) / 2, ( _box.min.y + _box.max.y ) / 2, _box.max.z + 0.04 );

	}

	dispose() {

		this.group.removeFromParent();
		this.tcp.traverse( ( child ) => {

			if ( child.geometry ) child.geometry.dispose();
			if ( child.material ) child.material.dispose();

		} );

	}

}

export { RobotView };
